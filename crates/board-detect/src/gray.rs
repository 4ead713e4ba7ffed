//! Grayscale buffers: the borrowed 8-bit input view and the internal `f32` image.

use crate::DetectError;

/// A borrowed 8-bit grayscale image: row `y` starts at byte `y * stride`, and pixel `(x, y)`
/// is `data[y * stride + x]`. Pixel `(x, y)` has its centre at coordinates `(x, y)` (OpenCV's
/// convention: the centre of the top-left pixel is `(0, 0)`, `x` right, `y` down).
#[derive(Debug, Clone, Copy)]
pub struct GrayView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a> GrayView<'a> {
    /// Wraps a buffer. Fails with [`DetectError::InvalidImage`] when a side is 0, the stride
    /// is smaller than the width, or the buffer is shorter than
    /// `(height - 1) * stride + width` bytes.
    pub fn new(
        data: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, DetectError> {
        if width == 0 || height == 0 {
            return Err(DetectError::InvalidImage(format!(
                "{width}x{height} image has no pixels"
            )));
        }
        if stride < width {
            return Err(DetectError::InvalidImage(format!(
                "stride {stride} < width {width}"
            )));
        }
        let needed = (height - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(width))
            .ok_or_else(|| DetectError::InvalidImage("buffer size overflows".into()))?;
        if data.len() < needed {
            return Err(DetectError::InvalidImage(format!(
                "buffer has {} bytes, {width}x{height} with stride {stride} needs {needed}",
                data.len()
            )));
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
        })
    }

    /// Wraps a tightly packed buffer (`stride == width`).
    pub fn packed(data: &'a [u8], width: usize, height: usize) -> Result<Self, DetectError> {
        Self::new(data, width, height, width)
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row `y` (`width` bytes). `y` must be below the height.
    pub(crate) fn row(&self, y: usize) -> &'a [u8] {
        &self.data[y * self.stride..y * self.stride + self.width]
    }
}

/// A dense `f32` image, row-major without padding.
#[derive(Debug, Clone)]
pub(crate) struct ImageF {
    pub w: usize,
    pub h: usize,
    pub data: Vec<f32>,
}

impl ImageF {
    pub fn from_view(v: &GrayView<'_>) -> Self {
        let mut data = Vec::with_capacity(v.width * v.height);
        for y in 0..v.height {
            data.extend(v.row(y).iter().map(|&b| b as f32));
        }
        Self {
            w: v.width,
            h: v.height,
            data,
        }
    }

    /// The sub-image `[x0, x1) x [y0, y1)` of a view (clamped to the view, at least one pixel).
    pub fn from_view_region(v: &GrayView<'_>, x0: usize, y0: usize, x1: usize, y1: usize) -> Self {
        let (x1, y1) = (x1.min(v.width).max(1), y1.min(v.height).max(1));
        let (x0, y0) = (x0.min(x1 - 1), y0.min(y1 - 1));
        let mut data = Vec::with_capacity((x1 - x0) * (y1 - y0));
        for y in y0..y1 {
            data.extend(v.row(y)[x0..x1].iter().map(|&b| b as f32));
        }
        Self {
            w: x1 - x0,
            h: y1 - y0,
            data,
        }
    }

    /// The image downscaled by an integer factor `f` (box average of `f x f` blocks). A
    /// point `(x, y)` of the result is at `(f x + (f - 1) / 2, f y + (f - 1) / 2)` in the source.
    pub fn from_view_downscaled(v: &GrayView<'_>, f: usize) -> Self {
        let (w, h) = (v.width / f, v.height / f);
        let mut acc = vec![0u32; w];
        let mut data = Vec::with_capacity(w * h);
        let norm = 1.0 / (f * f) as f32;
        for y in 0..h {
            acc.iter_mut().for_each(|a| *a = 0);
            for yy in 0..f {
                let row = v.row(y * f + yy);
                for (x, a) in acc.iter_mut().enumerate() {
                    *a += row[x * f..x * f + f].iter().map(|&b| b as u32).sum::<u32>();
                }
            }
            data.extend(acc.iter().map(|&a| a as f32 * norm));
        }
        Self { w, h, data }
    }

    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.w + x]
    }

    /// Bilinear interpolation with clamping at the border.
    #[inline]
    pub fn sample(&self, x: f64, y: f64) -> f32 {
        let xm = (self.w - 1) as f64;
        let ym = (self.h - 1) as f64;
        let x = x.clamp(0.0, xm);
        let y = y.clamp(0.0, ym);
        let x0 = (x.floor() as usize).min(self.w.saturating_sub(2));
        let y0 = (y.floor() as usize).min(self.h.saturating_sub(2));
        let fx = (x - x0 as f64) as f32;
        let fy = (y - y0 as f64) as f32;
        let x1 = (x0 + 1).min(self.w - 1);
        let y1 = (y0 + 1).min(self.h - 1);
        let a = self.at(x0, y0) + fx * (self.at(x1, y0) - self.at(x0, y0));
        let b = self.at(x0, y1) + fx * (self.at(x1, y1) - self.at(x0, y1));
        a + fy * (b - a)
    }

    /// Standard deviation of the image's pixel noise in grey levels, estimated robustly
    /// (Immerkaer's operator): the filter `[1 -2 1]^T [1 -2 1]` is zero on flat areas, on
    /// straight edges along the pixel axes and on linear ramps, and gives `6 sigma` RMS on
    /// independent noise; the median of its magnitude, every `step`-th pixel in each
    /// direction, divided by `0.6745 * 6`. Edges not along the axes and corners add to a
    /// minority of samples, which the median ignores. Noise correlated between neighbouring
    /// pixels (JPEG, demosaicing, sharpening) is partly missed. 0 for an image under 3 px a side.
    pub fn noise_sigma(&self, step: usize) -> f64 {
        let (w, h) = (self.w, self.h);
        if w < 3 || h < 3 {
            return 0.0;
        }
        let step = step.max(1);
        let mut v: Vec<f32> = Vec::with_capacity(((w - 2) / step + 1) * ((h - 2) / step + 1));
        for y in (1..h - 1).step_by(step) {
            let (up, mid, dn) = (
                &self.data[(y - 1) * w..y * w],
                &self.data[y * w..(y + 1) * w],
                &self.data[(y + 1) * w..(y + 2) * w],
            );
            for x in (1..w - 1).step_by(step) {
                let l = |row: &[f32]| row[x - 1] - 2.0 * row[x] + row[x + 1];
                v.push((l(up) - 2.0 * l(mid) + l(dn)).abs());
            }
        }
        let k = v.len() / 2;
        let (_, med, _) = v.select_nth_unstable_by(k, f32::total_cmp);
        f64::from(*med) / (0.6745 * 6.0)
    }

    /// Separable Gaussian blur with standard deviation `sigma` pixels (kernel radius
    /// `ceil(3 sigma)`), replicating the border.
    pub fn blurred(&self, sigma: f64) -> ImageF {
        if sigma <= 0.0 {
            return self.clone();
        }
        let r = (3.0 * sigma).ceil() as usize;
        let mut k: Vec<f32> = (0..=2 * r)
            .map(|i| {
                let d = i as f64 - r as f64;
                (-d * d / (2.0 * sigma * sigma)).exp() as f32
            })
            .collect();
        let s: f32 = k.iter().sum();
        k.iter_mut().for_each(|v| *v /= s);
        let (w, h) = (self.w, self.h);
        // Vertical pass first: every output row is a weighted sum of whole input rows, a
        // loop the compiler vectorizes.
        let mut tmp = vec![0f32; w * h];
        for y in 0..h {
            let out = &mut tmp[y * w..(y + 1) * w];
            for (i, &kv) in k.iter().enumerate() {
                let yy = (y as isize + i as isize - r as isize).clamp(0, h as isize - 1) as usize;
                let src = &self.data[yy * w..(yy + 1) * w];
                for (o, s) in out.iter_mut().zip(src) {
                    *o += kv * s;
                }
            }
        }
        // Horizontal pass on a border-padded copy of each row, as shifted weighted sums.
        let mut data = vec![0f32; w * h];
        let mut padded = vec![0f32; w + 2 * r];
        for y in 0..h {
            let row = &tmp[y * w..(y + 1) * w];
            padded[..r].fill(row[0]);
            padded[r..r + w].copy_from_slice(row);
            padded[r + w..].fill(row[w - 1]);
            let out = &mut data[y * w..(y + 1) * w];
            for (i, &kv) in k.iter().enumerate() {
                for (o, s) in out.iter_mut().zip(&padded[i..i + w]) {
                    *o += kv * s;
                }
            }
        }
        ImageF { w, h, data }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::SplitMix;

    /// The noise estimate recovers the noise added to a chessboard of 20 px squares turned by
    /// 0.4 rad (edges about 1 px wide) on a lighting ramp, within 5 % (the median of about 2000
    /// samples), and is small on the noiseless board: the edges are a minority of the samples.
    #[test]
    fn noise_estimate_recovers_the_added_noise() {
        let (w, h) = (100, 90);
        let mut rng = SplitMix(3);
        let (c, s) = (0.4f64.cos(), 0.4f64.sin());
        let step = |t: f64| (3.0 * (std::f64::consts::PI * t / 20.0).sin()).tanh();
        for noise in [0.0, 4.0, 20.0] {
            let data = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    let (u, v) = (c * x + s * y, -s * x + c * y);
                    (80.0 + 0.3 * x + 30.0 * step(u) * step(v) + noise * rng.normal()) as f32
                })
                .collect();
            let img = ImageF { w, h, data };
            let est = img.noise_sigma(2);
            if noise == 0.0 {
                assert!(est < 0.5, "noiseless: {est}");
            } else {
                assert!((est / noise - 1.0).abs() < 0.05, "noise {noise}: {est}");
            }
        }
    }
}
