//! Frames and images: the per-pixel results of a render, tone mapping to sRGB PNG, and the
//! nodes-visited heat map.

use crate::workload::{FrameStats, Integrator, PixelResult};
use rayon::prelude::*;
use rtsim_core::Vec3;
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
    /// Tone-mapped 8-bit sRGB pixels: `exposure` scales linear radiance, then values are
    /// clamped (no curve, so a value of 1 is white, matching AO images exactly).
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            let c: Vec3 = p.color * exposure;
            out.extend([
                linear_to_srgb8(c.x),
                linear_to_srgb8(c.y),
                linear_to_srgb8(c.z),
            ]);
        }
        out
    }

    /// Heat map of nodes visited per pixel, normalised to the 99th percentile (so a few
    /// extreme pixels do not wash the image out), coloured with a perceptual ramp.
    /// Returns the pixels and the value mapped to the top of the scale.
    pub fn heatmap_rgb8(&self) -> (Vec<u8>, u32) {
        let mut sorted: Vec<u32> = self.pixels.iter().map(|p| p.nodes_visited).collect();
        sorted.sort_unstable();
        let top = sorted
            .get((sorted.len() * 99 / 100).min(sorted.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0)
            .max(1);
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            out.extend(ramp(p.nodes_visited as f32 / top as f32));
        }
        (out, top)
    }
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

/// Write 8-bit RGB pixels as a PNG, atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    {
        let mut enc = png::Encoder::new(&mut file, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc.write_header().map_err(io::Error::other)?;
        w.write_image_data(rgb).map_err(io::Error::other)?;
        w.finish().map_err(io::Error::other)?;
    }
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(0.2159), 128); // sRGB 128/255 is linear 0.2159
    }

    #[test]
    fn ramp_ends() {
        assert_eq!(ramp(0.0), [68, 1, 84]);
        assert_eq!(ramp(1.0), [253, 231, 37]);
        assert_eq!(ramp(7.0), [253, 231, 37]);
    }
}
