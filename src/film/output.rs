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

fn save_rgb8(width: u32, height: u32, data: Vec<u8>, path: &Path) -> Result<()> {
    let buffer = image::RgbImage::from_raw(width, height, data).context("image buffer size")?;
    buffer
        .save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot write PNG", path.display()))
}

pub fn write_png(image: &Image, path: &Path, curve: ToneCurve) -> Result<()> {
    let data = image
        .pixels
        .iter()
        .flat_map(|p| [curve.encode(p.x), curve.encode(p.y), curve.encode(p.z)])
        .collect();
    save_rgb8(image.width, image.height, data, path)
}

pub fn write_exr(image: &Image, path: &Path, with_rate: bool) -> Result<()> {
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
    let layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(path)
        .with_context(|| format!("{}: cannot write EXR", path.display()))
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

/// Writes the per-pixel sample counts as a colour-coded PNG.
pub fn write_rate_png(image: &Image, path: &Path) -> Result<()> {
    let max = image.samples.iter().copied().max().unwrap_or(1).max(1) as f32;
    let data = image
        .samples
        .iter()
        .flat_map(|&n| {
            let c = rate_colour(n as f32 / max);
            [c.x, c.y, c.z].map(|v| (255.0 * v).round() as u8)
        })
        .collect();
    save_rgb8(image.width, image.height, data, path)
}

/// Reads an image written by [`write_image`] (or any RGB EXR/PNG) back as
/// linear RGB; PNGs are decoded as sRGB.
pub fn read_image(path: &Path) -> Result<Image> {
    match Format::from_path(path)? {
        Format::Exr => {
            use exr::prelude::*;
            let decoded = read_first_rgba_layer_from_file(
                path,
                |res, _| {
                    let (w, h) = (res.width(), res.height());
                    (w, vec![Vec3::ZERO; w * h])
                },
                |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
                },
            )
            .with_context(|| format!("{}: cannot read EXR", path.display()))?;
            let size = decoded.layer_data.size;
            let (_, pixels) = decoded.layer_data.channel_data.pixels;
            let mut image = super::Image::new(size.width() as u32, size.height() as u32);
            image.pixels = pixels;
            Ok(image)
        }
        Format::Png => {
            let rgb = image::open(path)
                .with_context(|| format!("{}: cannot read PNG", path.display()))?
                .to_rgb8();
            let mut image = Image::new(rgb.width(), rgb.height());
            // Inverse of the sRGB curve, the common encoding of PNGs.
            let decode = |v: u8| {
                let v = v as f32 / 255.0;
                if v <= 0.04045 {
                    v / 12.92
                } else {
                    ((v + 0.055) / 1.055).powf(2.4)
                }
            };
            for (dst, p) in image.pixels.iter_mut().zip(rgb.pixels()) {
                *dst = Vec3::new(decode(p[0]), decode(p[1]), decode(p[2]));
            }
            Ok(image)
        }
    }
}
