//! Writing images: 8-bit PNG with a tone curve, linear float EXR, and the
//! sample-rate image of adaptive sampling.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glam::Vec3;

use super::Image;

/// How linear radiance becomes an 8-bit value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ToneCurve {
    /// The CS184 renderer's curve: v = trunc(255·clamp((L·√2)^(1/2.2), 0, 1)).
    Reference,
    /// The sRGB transfer function, clamped, rounded.
    Srgb,
}

impl ToneCurve {
    #[inline]
    /// Inverse of [`encode`](Self::encode): the linear value at the middle
    /// of the code's interval (the reference curve truncates, sRGB rounds).
    pub fn decode(self, v: u8) -> f32 {
        match self {
            ToneCurve::Reference => {
                ((v as f32 + 0.5) / 255.0).min(1.0).powf(2.2) / std::f32::consts::SQRT_2
            }
            ToneCurve::Srgb => {
                let v = v as f32 / 255.0;
                if v <= 0.04045 {
                    v / 12.92
                } else {
                    ((v + 0.055) / 1.055).powf(2.4)
                }
            }
        }
    }

    pub fn encode(self, l: f32) -> u8 {
        if !l.is_finite() {
            return 0;
        }
        match self {
            ToneCurve::Reference => {
                let v = (l * std::f32::consts::SQRT_2)
                    .max(0.0)
                    .powf(1.0 / 2.2)
                    .min(1.0);
                (255.0 * v) as u8
            }
            ToneCurve::Srgb => {
                let l = l.clamp(0.0, 1.0);
                let v = if l <= 0.003_130_8 {
                    12.92 * l
                } else {
                    1.055 * l.powf(1.0 / 2.4) - 0.055
                };
                (255.0 * v).round() as u8
            }
        }
    }
}

/// Output format, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

impl Format {
    pub fn from_path(path: &Path) -> Result<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            _ => bail!(
                "{}: unknown output format (use a .png or .exr file name)",
                path.display()
            ),
        }
    }
}

/// Writes `image` to `path` in the format its extension names. EXR files get
/// an extra `samples` channel with per-pixel sample counts when `with_rate`.
pub fn write_image(image: &Image, path: &Path, curve: ToneCurve, with_rate: bool) -> Result<()> {
    match Format::from_path(path)? {
        Format::Png => write_png(image, path, curve),
        Format::Exr => write_exr(image, path, with_rate),
    }
}

/// Writes 8-bit RGB pixels (row by row, top first) as a PNG file.
///
/// The encoder writes through a buffer that is flushed here, so a failed
/// write (a full disk) is an error. `image`'s own `save` drops its buffer
/// unflushed, which loses the last write's error — and with it, silently,
/// the whole of a small image.
pub(crate) fn save_rgb8(width: u32, height: u32, data: &[u8], path: &Path) -> Result<()> {
    use image::ImageEncoder;
    use std::io::Write;
    let context = || format!("{}: cannot write PNG", path.display());
    let file = std::fs::File::create(path).with_context(context)?;
    let mut out = std::io::BufWriter::new(file);
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(data, width, height, image::ExtendedColorType::Rgb8)
        .with_context(context)?;
    out.flush().with_context(context)
}

pub fn write_png(image: &Image, path: &Path, curve: ToneCurve) -> Result<()> {
    let data: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| [curve.encode(p.x), curve.encode(p.y), curve.encode(p.z)])
        .collect();
    save_rgb8(image.width, image.height, &data, path)
}

pub fn write_exr(image: &Image, path: &Path, with_rate: bool) -> Result<()> {
    write_exr_channels(image, path, with_rate, false, &[])
}

/// Names of the EXR channels holding each pixel's standard error (the
/// square root of [`Image::variance`]), written by [`write_exr_with_error`].
pub const STDERR_CHANNELS: [&str; 3] = ["stderr.R", "stderr.G", "stderr.B"];

/// Writes an EXR with the per-pixel standard error of the mean as three
/// more channels ([`STDERR_CHANNELS`]) and the sample counts as `samples`,
/// so the file carries its own noise estimate (references for tests and
/// `wavepath converge`). [`read_image`] reads them back into `variance`.
/// `notes` become text attributes of the file's header (names and values
/// in ASCII), read back by [`read_exr_notes`].
pub fn write_exr_with_error(image: &Image, path: &Path, notes: &[(String, String)]) -> Result<()> {
    write_exr_channels(image, path, true, true, notes)
}

/// The text attributes of an EXR's first header, as (name, value).
pub fn read_exr_notes(path: &Path) -> Result<Vec<(String, String)>> {
    use exr::meta::attribute::AttributeValue;
    let meta = read_exr_header(path)?;
    let Some(header) = meta.headers.first() else {
        return Ok(Vec::new());
    };
    let mut notes: Vec<(String, String)> = header
        .own_attributes
        .other
        .iter()
        .filter_map(|(name, value)| match value {
            AttributeValue::Text(text) => Some((name.to_string(), text.to_string())),
            _ => None,
        })
        .collect();
    notes.sort();
    Ok(notes)
}

fn write_exr_channels(
    image: &Image,
    path: &Path,
    with_rate: bool,
    with_error: bool,
    notes: &[(String, String)],
) -> Result<()> {
    use exr::prelude::*;
    let size = (image.width as usize, image.height as usize);
    // Non-finite radiance never reaches a file: it is written as 0.
    let channel = |f: fn(&Vec3) -> f32| -> Vec<f32> {
        image
            .pixels
            .iter()
            .map(|p| {
                let v = f(p);
                if v.is_finite() { v } else { 0.0 }
            })
            .collect()
    };
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    channels.push(AnyChannel::new("B", FlatSamples::F32(channel(|p| p.z))));
    channels.push(AnyChannel::new("G", FlatSamples::F32(channel(|p| p.y))));
    channels.push(AnyChannel::new("R", FlatSamples::F32(channel(|p| p.x))));
    if with_rate {
        let samples = image.samples.iter().map(|&n| n as f32).collect();
        channels.push(AnyChannel::new("samples", FlatSamples::F32(samples)));
    }
    if with_error {
        for (c, name) in STDERR_CHANNELS.iter().enumerate() {
            let se = image
                .variance
                .iter()
                .map(|v| v[c].max(0.0).sqrt())
                .collect();
            channels.push(AnyChannel::new(*name, FlatSamples::F32(se)));
        }
    }
    let mut attributes = LayerAttributes::default();
    for (name, value) in notes {
        let text = |t: &str| {
            Text::new_or_none(t).with_context(|| {
                format!("{}: EXR attribute '{t}' is not ASCII text", path.display())
            })
        };
        attributes
            .other
            .insert(text(name)?, AttributeValue::Text(text(value)?));
    }
    let layer = Layer::new(
        size,
        attributes,
        // Blocks in increasing order: with the default (unspecified) order,
        // parallel compression writes them as they finish, so the same
        // image gave different files.
        Encoding {
            line_order: exr::meta::attribute::LineOrder::Increasing,
            ..Encoding::FAST_LOSSLESS
        },
        AnyChannels::sort(channels),
    );
    // The exr crate's I/O error names its cause again as its source, so
    // it is formatted here once rather than chained.
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| anyhow::anyhow!("{}: cannot write EXR: {e}", path.display()))
}

/// `<stem>_rate.png` beside `path`.
pub fn rate_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    path.with_file_name(format!("{stem}_rate.png"))
}

/// Colour for a sample rate in [0, 1]: blue (few) → green → red (the maximum).
pub fn rate_colour(rate: f32) -> Vec3 {
    let r = rate.clamp(0.0, 1.0);
    if r <= 0.5 {
        let g = 2.0 * r;
        Vec3::new(0.0, g, 1.0 - g)
    } else {
        let red = 2.0 * r - 1.0;
        Vec3::new(red, 1.0 - red, 0.0)
    }
}

/// Writes the per-pixel sample counts as a colour-coded PNG, coded as the
/// reference codes them: the rate is a pixel's count over `max_samples`
/// (`-s`), so a render whose pixels all stopped early shows no red, and
/// each channel is written as trunc(255·c), linear.
pub fn write_rate_png(image: &Image, max_samples: u32, path: &Path) -> Result<()> {
    let max = max_samples.max(1) as f32;
    let data: Vec<u8> = image
        .samples
        .iter()
        .flat_map(|&n| {
            let c = rate_colour(n as f32 / max);
            [c.x, c.y, c.z].map(|v| (255.0 * v) as u8)
        })
        .collect();
    save_rgb8(image.width, image.height, &data, path)
}

/// Reads an image written by [`write_image`] (or any RGB EXR/PNG) back as
/// linear RGB; PNGs are decoded as sRGB. From an EXR, the optional
/// `samples` and [`STDERR_CHANNELS`] channels fill `samples` and `variance`.
pub fn read_image(path: &Path) -> Result<Image> {
    read_image_with(path, ToneCurve::Srgb)
}

/// [`read_image`], decoding PNGs with the inverse of `curve`.
pub fn read_image_with(path: &Path, curve: ToneCurve) -> Result<Image> {
    match Format::from_path(path)? {
        Format::Exr => read_exr(path),
        Format::Png => {
            let rgb = image::open(path)
                .with_context(|| format!("{}: cannot read PNG", path.display()))?
                .to_rgb8();
            let mut image = Image::new(rgb.width(), rgb.height());
            // Inverse of the sRGB curve, the common encoding of PNGs.
            for (dst, p) in image.pixels.iter_mut().zip(rgb.pixels()) {
                *dst = Vec3::new(curve.decode(p[0]), curve.decode(p[1]), curve.decode(p[2]));
            }
            Ok(image)
        }
    }
}

/// Refuses a file whose header claims more than [`MAX_PIXELS`](super::MAX_PIXELS)
/// pixels: a few hundred bytes can claim 1e10, which a decoder would try to
/// allocate before finding the data missing.
fn check_claimed_size(path: &Path, format: &str, width: u64, height: u64) -> Result<()> {
    if width * height > super::MAX_PIXELS {
        bail!(
            "{}: the {format} claims {width}x{height} pixels, more than the 2^{} this program reads",
            path.display(),
            super::MAX_PIXELS.trailing_zeros()
        );
    }
    Ok(())
}

/// Reads a Radiance RGBE file (`.hdr`, a common format of downloaded
/// latitude–longitude maps) as linear RGB.
pub fn read_radiance_hdr(path: &Path) -> Result<RgbImage> {
    use image::ImageDecoder;
    let cannot = |e: &dyn std::fmt::Display| {
        anyhow::anyhow!("{}: cannot read Radiance HDR: {e}", path.display())
    };
    let file = std::fs::File::open(path).map_err(|e| cannot(&e))?;
    let decoder = image::codecs::hdr::HdrDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| cannot(&e))?;
    let (width, height) = decoder.dimensions();
    check_claimed_size(path, "Radiance HDR file", width.into(), height.into())?;
    let decoded = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| cannot(&e))?
        .into_rgb32f();
    let pixels = decoded.pixels().map(|p| Vec3::from(p.0)).collect();
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

fn cannot_read_exr(path: &Path, e: exr::error::Error) -> anyhow::Error {
    anyhow::anyhow!("{}: cannot read EXR: {e}", path.display())
}

/// An EXR's headers. A file that does not start with the EXR magic number
/// is called what it is, rather than given the decoder's view of its bytes.
fn read_exr_header(path: &Path) -> Result<exr::meta::MetaData> {
    use std::io::Read;
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    let mut start = Vec::with_capacity(4);
    std::fs::File::open(path)
        .and_then(|f| f.take(4).read_to_end(&mut start))
        .with_context(|| format!("{}: cannot read EXR", path.display()))?;
    if start != MAGIC {
        bail!(
            "{}: not an OpenEXR file (it does not start with the EXR magic number)",
            path.display()
        );
    }
    exr::meta::MetaData::read_from_file(path, false).map_err(|e| cannot_read_exr(path, e))
}

/// One decoded EXR layer: every channel's samples, whatever their type.
type ExrLayer = exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>;

/// The first layer of an EXR, decoded, with its width and height.
fn decode_exr(path: &Path) -> Result<(ExrLayer, usize, usize)> {
    use exr::prelude::read_first_flat_layer_from_file;
    // The header first: a few hundred bytes can claim 1e10 pixels, which
    // the decoder would try to allocate before finding the data missing.
    let meta = read_exr_header(path)?;
    for header in &meta.headers {
        let size = header.layer_size;
        check_claimed_size(path, "EXR", size.0 as u64, size.1 as u64)?;
    }
    let decoded = read_first_flat_layer_from_file(path).map_err(|e| cannot_read_exr(path, e))?;
    let layer = decoded.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    // Subsampled channels (e.g. chroma) have fewer samples than pixels.
    if let Some(c) = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.sample_data.len() != w * h)
    {
        bail!(
            "{}: EXR channel {} is subsampled, which is not supported",
            path.display(),
            c.name
        );
    }
    Ok((layer, w, h))
}

/// The samples of the channel called `name` (any case), if the layer has one.
fn exr_channel<'a>(layer: &'a ExrLayer, name: &str) -> Option<&'a exr::prelude::FlatSamples> {
    layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.eq_case_insensitive(name))
        .map(|c| &c.sample_data)
}

/// Three channels' samples as RGB pixels.
fn rgb_values<'a>(
    [r, g, b]: [&'a exr::prelude::FlatSamples; 3],
) -> impl Iterator<Item = Vec3> + 'a {
    r.values_as_f32()
        .zip(g.values_as_f32())
        .zip(b.values_as_f32())
        .map(|((r, g), b)| Vec3::new(r, g, b))
}

/// The colour channels of a decoded layer: R, G, B, or Y for grey.
fn exr_colour<'a>(path: &Path, layer: &'a ExrLayer) -> Result<impl Iterator<Item = Vec3> + 'a> {
    let find = |name| exr_channel(layer, name);
    let rgb = match (find("R"), find("G"), find("B")) {
        (Some(r), Some(g), Some(b)) => [r, g, b],
        _ => match find("Y") {
            Some(y) => [y, y, y],
            None => bail!("{}: EXR has no R, G, B (or Y) channels", path.display()),
        },
    };
    Ok(rgb_values(rgb))
}

/// Linear RGB pixels, row 0 at the top: all that an environment map
/// takes from its file.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// Reads the colour of an OpenEXR (`.exr`) or Radiance HDR (`.hdr`)
/// image, nothing else: no [`Image`] with its variance and sample planes
/// (which would double the memory a large map takes while it loads).
/// Any other extension is refused, by name.
pub fn read_rgb(path: &Path) -> Result<RgbImage> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("hdr") {
        return read_radiance_hdr(path);
    }
    if !extension.eq_ignore_ascii_case("exr") {
        bail!(
            "{}: environment maps are read from OpenEXR (.exr) or Radiance HDR (.hdr) files",
            path.display()
        );
    }
    let (layer, w, h) = decode_exr(path)?;
    let pixels = exr_colour(path, &layer)?.collect();
    Ok(RgbImage {
        width: w as u32,
        height: h as u32,
        pixels,
    })
}

/// Reads the first layer of an EXR: R, G, B (or Y for grey) are required.
fn read_exr(path: &Path) -> Result<Image> {
    let (layer, w, h) = decode_exr(path)?;
    // Channels are read in place, not copied: the decoded layer and the
    // image are all a reference takes in memory.
    let find = |name| exr_channel(&layer, name);
    let colour = exr_colour(path, &layer)?;
    let mut image = super::Image::new(w as u32, h as u32);
    for (dst, v) in image.pixels.iter_mut().zip(colour) {
        *dst = v;
    }
    if let Some(n) = find("samples") {
        for (dst, v) in image.samples.iter_mut().zip(n.values_as_f32()) {
            *dst = v.max(0.0) as u32;
        }
    }
    if let [Some(r), Some(g), Some(b)] = STDERR_CHANNELS.map(find) {
        for (i, (dst, v)) in image
            .variance
            .iter_mut()
            .zip(rgb_values([r, g, b]))
            .enumerate()
        {
            let variance = v * v;
            // A standard error is a finite non-negative number whose square
            // is too (a NaN here would turn every error figure into NaN).
            if let Some(c) = (0..3).find(|&c| !(v[c] >= 0.0 && variance[c].is_finite())) {
                let (x, y) = (i % w, i / w);
                bail!(
                    "{}: channel {} at pixel ({x}, {y}) is {}, not a standard error (a finite \
                     number ≥ 0 whose square is finite)",
                    path.display(),
                    STDERR_CHANNELS[c],
                    v[c]
                );
            }
            *dst = variance;
        }
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::{ToneCurve, rate_colour};
    use glam::Vec3;

    /// Blue at no samples, green at half of `-s`, red at all of it,
    /// linear in between, and clamped outside [0, 1]. (The CLI test of
    /// the rate image sees adaptive renders whose pixels stop early, so
    /// only the blue half.)
    #[test]
    fn rate_colours_run_blue_green_red() {
        let cases = [
            (-1.0, Vec3::Z),
            (0.0, Vec3::Z),
            (0.25, Vec3::new(0.0, 0.5, 0.5)),
            (0.5, Vec3::Y),
            (0.75, Vec3::new(0.5, 0.5, 0.0)),
            (1.0, Vec3::X),
            (2.0, Vec3::X),
        ];
        for (rate, colour) in cases {
            assert_eq!(rate_colour(rate), colour, "rate {rate}");
        }
    }

    #[test]
    fn decode_inverts_encode() {
        for curve in [ToneCurve::Reference, ToneCurve::Srgb] {
            for v in 0..=255u8 {
                assert_eq!(curve.encode(curve.decode(v)), v, "{curve:?} code {v}");
            }
        }
    }
}
