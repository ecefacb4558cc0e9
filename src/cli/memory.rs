//! Whether a render's image fits in memory, found out before anything is
//! loaded: an image too large for the machine would otherwise end in an
//! allocation failure (an abort, not an error message) or the kernel's
//! out-of-memory killer, after the scene had loaded and rendered.
//!
//! Only what grows with `-r` is counted, exactly: for a render, the
//! finished image, the sums of the pixels being rendered (all of them up
//! to 2^21 pixels, which take their passes together; see
//! [`pass_state_bytes`]) and the buffer its file is encoded from; for
//! `converge`, the two images it holds at once (see there) and the same
//! sums. The scene, BVH, threads and allocator come
//! on top, so a render that passes may still not fit; one that fails
//! certainly would not. The memory available is read from Linux's /proc
//! (what the kernel could give without swapping anything else out, plus
//! free swap, and the process's address-space limit, `ulimit -v`);
//! elsewhere nothing is checked.

use crate::film::Image;
use crate::film::output::Format;
use crate::wavefront::{PASS_STATE_BYTES_PER_PIXEL, PROGRESSIVE_PIXELS, pass_state_bytes};

/// Bytes per pixel of the buffer an image file is encoded from: 8-bit
/// RGB for a PNG; f32 R, G, B and the sample count for an EXR.
pub fn encoding_bytes_per_pixel(format: Format) -> u64 {
    match format {
        Format::Png => 3,
        Format::Exr => 4 * std::mem::size_of::<f32>() as u64,
    }
}

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

/// The refusal for an image of `pixels` pixels written as `format` that
/// cannot fit, or None (also when the machine does not say what is
/// available).
pub fn image_does_not_fit(pixels: u64, format: Format) -> Option<String> {
    let name = match format {
        Format::Png => "PNG",
        Format::Exr => "EXR",
    };
    let per_pixel = Image::BYTES_PER_PIXEL + encoding_bytes_per_pixel(format);
    does_not_fit(
        pixels,
        per_pixel,
        &format!("the image and its {name} encoding"),
    )
}

/// The refusal when `what`, `per_pixel` bytes for each of `pixels`
/// pixels, and the sums of the pixels being rendered cannot fit, or None
/// (also when the machine does not say what is available).
pub fn does_not_fit(pixels: u64, per_pixel: u64, what: &str) -> Option<String> {
    let read = |path: &str| std::fs::read_to_string(path).unwrap_or_default();
    let free = available(
        &read("/proc/meminfo"),
        &read("/proc/self/limits"),
        &read("/proc/self/status"),
    )?;
    refusal(pixels, per_pixel, what, free)
}

/// The message when `what`, `per_pixel` bytes for each of `pixels` pixels,
/// and the sums of the pixels being rendered need more than `free` bytes.
fn refusal(pixels: u64, per_pixel: u64, what: &str, free: u64) -> Option<String> {
    let need = pixels * per_pixel + pass_state_bytes(pixels);
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    (need > free).then(|| {
        format!(
            "{what} and the sums of the pixels being rendered alone need {:.1} GiB \
             ({per_pixel} bytes per pixel, and {PASS_STATE_BYTES_PER_PIXEL} for each of \
             at most {PROGRESSIVE_PIXELS} pixels rendered at once), and {:.1} GiB of memory \
             is available",
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
    fn an_image_that_does_not_fit_is_refused_with_both_sizes() {
        assert_eq!(Image::BYTES_PER_PIXEL, 28);
        let pixels = 16000 * 16000;
        let exr = Image::BYTES_PER_PIXEL + encoding_bytes_per_pixel(Format::Exr);
        let png = Image::BYTES_PER_PIXEL + encoding_bytes_per_pixel(Format::Png);
        assert_eq!((exr, png), (44, 31));
        let e = refusal(pixels, exr, "the image and its EXR encoding", 4 << 30).unwrap();
        // 16000² · 44 bytes and 2^21 · 72 bytes of sums.
        assert_eq!(
            e,
            "the image and its EXR encoding and the sums of the pixels being rendered alone \
             need 10.6 GiB (44 bytes per pixel, and 72 for each of at most 2097152 pixels \
             rendered at once), and 4.0 GiB of memory is available"
        );
        let sums = (1 << 21) * 72;
        assert_eq!(refusal(pixels, png, "", pixels * 31 + sums), None);
        assert!(refusal(pixels, png, "", pixels * 31 + sums - 1).is_some());
        // A small image's pixels are all rendered at once.
        assert_eq!(pass_state_bytes(1000), 72_000);
        assert!(refusal(1000, png, "", 1000 * (31 + 72) - 1).is_some());
        assert_eq!(refusal(1000, png, "", 1000 * (31 + 72)), None);
    }
}
