//! Whether a render's film fits in memory, found out before anything is
//! loaded: an image too large for the machine would otherwise end in an
//! allocation failure (an abort, not an error message) or the kernel's
//! out-of-memory killer, after the scene had loaded.
//!
//! Only the film is counted: it is what grows with `-r`, and it is exact
//! (the per-pixel sums of every tile, then the finished image they are
//! stored into). The scene, BVH and output encoding come on top, so a
//! render that passes may still not fit; one that fails certainly would
//! not. The memory available is read from Linux's /proc (what the kernel
//! could give without swapping anything else out, plus free swap, and the
//! process's address-space limit, `ulimit -v`); elsewhere nothing is
//! checked.

/// Bytes of film per rendered pixel at its peak: every tile's sums (f64
/// radiance and its square, f64 illuminance and its square, a u32 count)
/// alive while they are stored into the image (f32 mean and variance, a
/// u32 count).
pub const FILM_BYTES_PER_PIXEL: u64 = {
    use std::mem::size_of;
    (2 * size_of::<glam::DVec3>()
        + 2 * size_of::<f64>()
        + size_of::<u32>()
        + 2 * size_of::<glam::Vec3>()
        + size_of::<u32>()) as u64
};

/// The bytes this process may still allocate, as far as Linux says:
/// `MemAvailable` + `SwapFree` from `meminfo`, capped by the soft address
/// space limit of `limits` less the `VmSize` of `status` (the texts of
/// /proc/meminfo, /proc/self/limits and /proc/self/status). None when
/// `meminfo` says nothing usable.
pub fn available(meminfo: &str, limits: &str, status: &str) -> Option<u64> {
    // "Name:   1234 kB"
    let kib = |text: &str, name: &str| -> Option<u64> {
        let line = text.lines().find(|l| l.starts_with(name))?;
        let value = line[name.len()..].split_whitespace().next()?;
        value.parse::<u64>().ok().map(|k| k * 1024)
    };
    let memory = kib(meminfo, "MemAvailable:")? + kib(meminfo, "SwapFree:").unwrap_or(0);
    // "Max address space   unlimited   unlimited   bytes"
    let address_limit = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))
        .and_then(|l| l["Max address space".len()..].split_whitespace().next())
        .and_then(|soft| soft.parse::<u64>().ok());
    Some(match address_limit {
        Some(limit) => {
            let used = kib(status, "VmSize:").unwrap_or(0);
            memory.min(limit.saturating_sub(used))
        }
        None => memory,
    })
}

/// The refusal for a film of `pixels` pixels that cannot fit, or None
/// (also when the machine does not say what is available).
pub fn film_does_not_fit(pixels: u64) -> Option<String> {
    let read = |path: &str| std::fs::read_to_string(path).unwrap_or_default();
    let free = available(
        &read("/proc/meminfo"),
        &read("/proc/self/limits"),
        &read("/proc/self/status"),
    )?;
    refusal(pixels, free)
}

/// The message when the film of `pixels` pixels needs more than `free` bytes.
fn refusal(pixels: u64, free: u64) -> Option<String> {
    let need = pixels * FILM_BYTES_PER_PIXEL;
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    (need > free).then(|| {
        format!(
            "its film alone needs {:.1} GiB ({FILM_BYTES_PER_PIXEL} bytes per pixel), \
             and {:.1} GiB of memory is available",
            gib(need),
            gib(free)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MEMINFO: &str = "MemTotal:       25165824 kB\n\
                           MemFree:         1000000 kB\n\
                           MemAvailable:   20000000 kB\n\
                           SwapTotal:       2097152 kB\n\
                           SwapFree:        1000000 kB\n";

    #[test]
    fn available_memory_is_ram_and_swap_within_the_address_limit() {
        let unlimited =
            "Max address space         unlimited            unlimited            bytes\n";
        let status = "VmSize:\t  100000 kB\n";
        assert_eq!(
            available(MEMINFO, unlimited, status),
            Some(21_000_000 * 1024)
        );
        // ulimit -v 4000000 (KiB), of which the process uses 100000 KiB.
        let limited = "Max address space         4096000000           unlimited            bytes\n";
        assert_eq!(
            available(MEMINFO, limited, status),
            Some(4_096_000_000 - 100_000 * 1024)
        );
        // Without MemAvailable (not Linux, or a kernel before 3.14): no check.
        assert_eq!(available("MemFree: 5 kB\n", unlimited, status), None);
        assert_eq!(available("", "", ""), None);
    }

    #[test]
    fn a_film_that_does_not_fit_is_refused_with_both_sizes() {
        assert_eq!(FILM_BYTES_PER_PIXEL, 96);
        let pixels = 16000 * 16000;
        let e = refusal(pixels, 4 << 30).unwrap();
        assert_eq!(
            e,
            "its film alone needs 22.9 GiB (96 bytes per pixel), and 4.0 GiB of memory is available"
        );
        assert_eq!(refusal(pixels, pixels * 96), None);
        assert!(refusal(pixels, pixels * 96 - 1).is_some());
    }
}
