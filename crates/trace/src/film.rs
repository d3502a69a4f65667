//! Frames and images: the per-pixel results of a render, tone mapping to sRGB PNG, and the
//! nodes-visited heat map.

use crate::workload::{FrameStats, Integrator, PixelResult};
use rayon::prelude::*;
use rtsim_core::output::AtomicFile;
use std::io;
use std::path::Path;

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<PixelResult>,
    pub stats: FrameStats,
}

/// Render every pixel. Rows are traced in parallel on the current rayon pool; each row's
/// stats are summed in row order, and each pixel's rays depend only on its coordinates and the
/// seed, so the frame is bit-identical for any thread count. `progress` is called once per
/// finished row.
pub fn render_frame(integ: &Integrator<'_>, progress: &(dyn Fn() + Sync)) -> Frame {
    let (w, h) = (integ.params().width, integ.params().height);
    let mut pixels = vec![PixelResult::default(); w as usize * h as usize];
    let row_stats: Vec<FrameStats> = pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .map(|(y, row)| {
            let mut st = FrameStats::default();
            for (x, px) in row.iter_mut().enumerate() {
                *px = integ.pixel(x as u32, y as u32, &mut st);
            }
            progress();
            st
        })
        .collect();
    let mut stats = FrameStats::default();
    for s in row_stats {
        stats += s;
    }
    Frame {
        width: w,
        height: h,
        pixels,
        stats,
    }
}

/// How linear radiance becomes display values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneMap {
    /// Multiply by `exposure`, then clamp to [0, 1] (AO images: 1 is white).
    Linear { exposure: f32 },
    /// Scale the frame's log-average luminance to the middle-grey key, then compress with
    /// Reinhard's `L / (1 + L)`: well exposed whatever the light's intensity.
    Auto,
    /// As [`ToneMap::Auto`], with the log-average luminance given: the whole frame's, for an
    /// image that holds only part of it (a simulated window, black around it).
    AutoFrom { log_average: f32 },
}

/// Middle grey (Reinhard et al. 2002, §3.1).
const AUTO_KEY: f32 = 0.18;

/// Linear value to an 8-bit sRGB code (IEC 61966-2-1 transfer function), clamping to [0, 1].
#[inline]
pub fn linear_to_srgb8(v: f32) -> u8 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

impl Frame {
    /// Tone-mapped 8-bit sRGB pixels.
    pub fn to_srgb8(&self, tone: ToneMap) -> Vec<u8> {
        let (scale, curve) = match tone {
            ToneMap::Linear { exposure } => (exposure, false),
            ToneMap::Auto => (AUTO_KEY / self.log_average_luminance(), true),
            ToneMap::AutoFrom { log_average } => (AUTO_KEY / log_average, true),
        };
        let map = |v: f32| {
            let v = v * scale;
            linear_to_srgb8(if curve { v / (1.0 + v) } else { v })
        };
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            out.extend([map(p.color.x), map(p.color.y), map(p.color.z)]);
        }
        out
    }

    /// Geometric mean of pixel luminance (Rec. 709 weights), the "key" of Reinhard et al.,
    /// "Photographic Tone Reproduction for Digital Images", SIGGRAPH 2002, eq. 1; 1 for an
    /// all-black frame.
    pub fn log_average_luminance(&self) -> f32 {
        // δ avoids log(0) for black pixels (Reinhard's small value).
        const DELTA: f64 = 1e-4;
        if self.pixels.is_empty() {
            return 1.0;
        }
        let sum: f64 = self
            .pixels
            .iter()
            .map(|p| {
                let c = p.color;
                let l = (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z).max(0.0) as f64;
                (DELTA + if l.is_finite() { l } else { 0.0 }).ln()
            })
            .sum();
        let avg = (sum / self.pixels.len() as f64).exp() as f32;
        if avg > DELTA as f32 * 1.01 { avg } else { 1.0 }
    }

    /// Heat map of nodes visited per pixel, normalised to the 99th percentile (so a few
    /// extreme pixels do not wash the image out), coloured with a perceptual ramp.
    /// Returns the pixels and the value mapped to the top of the scale.
    pub fn heatmap_rgb8(&self) -> (Vec<u8>, u32) {
        let values: Vec<u64> = self.pixels.iter().map(|p| p.nodes_visited as u64).collect();
        let (rgb, top) = heatmap_rgb8(&values);
        (rgb, top.min(u32::MAX as u64) as u32)
    }
}

/// A heat map of any per-pixel quantity (nodes visited, cycles), scaled to its 99th
/// percentile so a few extreme pixels do not wash out the rest; returns the pixels and the
/// value mapped to the top of the ramp.
pub fn heatmap_rgb8(values: &[u64]) -> (Vec<u8>, u64) {
    let mut sorted = values.to_vec();
    sorted.sort_unstable();
    let top = sorted
        .get((sorted.len() * 99 / 100).min(sorted.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0)
        .max(1);
    let mut out = Vec::with_capacity(values.len() * 3);
    for &v in values {
        out.extend(ramp((v as f64 / top as f64) as f32));
    }
    (out, top)
}

/// A perceptual ramp (dark blue → teal → yellow), piecewise linear through viridis' key
/// colours (van der Walt & Smith, matplotlib 2015).
fn ramp(x: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = |k: usize| (STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f + 0.5) as u8;
    [c(0), c(1), c(2)]
}

/// Encode 8-bit RGB pixels as a PNG into `w`.
pub fn encode_png<W: io::Write>(w: W, width: u32, height: u32, rgb: &[u8]) -> io::Result<()> {
    let mut enc = png::Encoder::new(w, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut w = enc.write_header().map_err(io::Error::other)?;
    w.write_image_data(rgb).map_err(io::Error::other)?;
    w.finish().map_err(io::Error::other)
}

/// 8-bit RGB pixels as PNG bytes.
pub fn png_bytes(width: u32, height: u32, rgb: &[u8]) -> io::Result<Vec<u8>> {
    let mut out = Vec::new();
    encode_png(&mut out, width, height, rgb)?;
    Ok(out)
}

/// Write 8-bit RGB pixels as a PNG, atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    encode_png(&mut file, width, height, rgb)?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtsim_core::Vec3;

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(0.2159), 128); // sRGB 128/255 is linear 0.2159
    }

    fn frame(colors: &[f32]) -> Frame {
        Frame {
            width: colors.len() as u32,
            height: 1,
            pixels: colors
                .iter()
                .map(|&c| PixelResult {
                    color: Vec3::splat(c),
                    nodes_visited: 0,
                })
                .collect(),
            stats: FrameStats::default(),
        }
    }

    #[test]
    fn auto_exposure_is_scale_invariant() {
        let a = frame(&[0.1, 0.5, 2.0, 8.0]).to_srgb8(ToneMap::Auto);
        let b = frame(&[1.0, 5.0, 20.0, 80.0]).to_srgb8(ToneMap::Auto);
        for (x, y) in a.iter().zip(&b) {
            assert!((*x as i32 - *y as i32).abs() <= 1);
        }
        // The log-average pixel lands on middle grey compressed: 0.18 / 1.18.
        let f = frame(&[1.0, 1.0]);
        assert_eq!(f.to_srgb8(ToneMap::Auto)[0], linear_to_srgb8(0.18 / 1.18));
        assert_eq!(frame(&[0.0, 0.0]).to_srgb8(ToneMap::Auto)[0], 0);
    }

    #[test]
    fn a_given_key_maps_like_the_frame_it_came_from() {
        // A window is tone-mapped with the whole frame's key: the same bytes as the frame.
        let whole = frame(&[0.1, 0.5, 2.0, 8.0]);
        let key = whole.log_average_luminance();
        assert_eq!(
            whole.to_srgb8(ToneMap::AutoFrom { log_average: key }),
            whole.to_srgb8(ToneMap::Auto)
        );
        // A frame black outside a window has a lower key than the whole frame's.
        assert!(frame(&[0.0, 0.5, 2.0, 0.0]).log_average_luminance() < key);
    }

    #[test]
    fn linear_clamps() {
        assert_eq!(
            frame(&[0.5, 2.0]).to_srgb8(ToneMap::Linear { exposure: 1.0 })[3],
            255
        );
    }

    #[test]
    fn ramp_ends() {
        assert_eq!(ramp(0.0), [68, 1, 84]);
        assert_eq!(ramp(1.0), [253, 231, 37]);
        assert_eq!(ramp(7.0), [253, 231, 37]);
    }
}
