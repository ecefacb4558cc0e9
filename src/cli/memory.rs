//! Whether a render's image fits in memory, found out before anything is
//! loaded: an image too large for the machine would otherwise end in an
//! allocation failure (an abort, not an error message) or the kernel's
//! out-of-memory killer, after the scene had loaded and rendered.
//!
//! Only what grows with `-r` is counted: for a render, the finished image
//! and, at the most, either the sums of the pixels being rendered (all of
//! them up to 2^21 pixels, which take their passes together; see
//! [`pass_state_bytes`]) or, once those are freed, the buffer the file is
//! encoded from; for `converge`, the two images it holds at once (see
//! there) and the same sums. The scene, BVH, threads and allocator come
//! on top, so a render that passes may still not fit; one that fails
//! certainly would not. The memory available is read from Linux's /proc
//! (what the kernel could give without swapping anything else out, plus
//! free swap, and the process's address-space limit, `ulimit -v`);
//! elsewhere nothing is checked.

use crate::film::Image;
use crate::film::output::Format;
use crate::wavefront::pass_state_bytes;

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

/// The refusal for a render of `pixels` pixels written as `format` that
/// cannot fit, or None (also when the machine does not say what is
/// available).
pub fn image_does_not_fit(pixels: u64, format: Format) -> Option<String> {
    let name = match format {
        Format::Png => "PNG",
        Format::Exr => "EXR",
    };
    let what = format!("the image, the sums of the pixels being rendered and the {name} encoding");
    does_not_fit(render_need(pixels, format), &what)
}

/// The most a render of `pixels` pixels written as `format` holds at
/// once: its image, with the pass sums while it renders, then with the
/// encoding buffer.
fn render_need(pixels: u64, format: Format) -> u64 {
    let encoding = pixels * encoding_bytes_per_pixel(format);
    pixels * Image::BYTES_PER_PIXEL + pass_state_bytes(pixels).max(encoding)
}

/// The refusal for `converge`'s renders of `pixels` pixels, which hold
/// `per_pixel` bytes a pixel of their own (`what`) besides the pass sums,
/// or None.
pub fn converge_does_not_fit(pixels: u64, per_pixel: u64, what: &str) -> Option<String> {
    does_not_fit(
        pixels * per_pixel + pass_state_bytes(pixels),
        &format!("{what}, and the sums of the pixels being rendered,"),
    )
}

/// The refusal when `what`, `need` bytes, cannot fit, or None (also when
/// the machine does not say what is available).
fn does_not_fit(need: u64, what: &str) -> Option<String> {
    let read = |path: &str| std::fs::read_to_string(path).unwrap_or_default();
    let free = available(
        &read("/proc/meminfo"),
        &read("/proc/self/limits"),
        &read("/proc/self/status"),
    )?;
    refusal(need, what, free)
}

/// The message when `what` needs `need` bytes, more than `free`.
fn refusal(need: u64, what: &str, free: u64) -> Option<String> {
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    (need > free).then(|| {
        format!(
            "{what} need {:.1} GiB, and {:.1} GiB of memory is available",
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
        assert_eq!(encoding_bytes_per_pixel(Format::Png), 3);
        assert_eq!(encoding_bytes_per_pixel(Format::Exr), 16);
        // The image and the larger of its pixels' sums (72 bytes each,
        // for at most 2^21 pixels) and its encoding.
        let pixels = 16000 * 16000;
        assert_eq!(render_need(pixels, Format::Exr), pixels * (28 + 16));
        assert_eq!(render_need(pixels, Format::Png), pixels * (28 + 3));
        let hd = 1920 * 1080;
        assert_eq!(render_need(hd, Format::Exr), hd * (28 + 72));
        let sums = (1 << 21) * 72;
        assert_eq!(render_need(40_000_000, Format::Png), 40_000_000 * 28 + sums);
        let e = refusal(pixels * 44, "the image and so on", 4 << 30).unwrap();
        assert_eq!(
            e,
            "the image and so on need 10.5 GiB, and 4.0 GiB of memory is available"
        );
        assert_eq!(refusal(5, "", 5), None);
        assert!(refusal(6, "", 5).is_some());
    }
}
