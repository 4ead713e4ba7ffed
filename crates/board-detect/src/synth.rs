//! Synthetic chessboard images with exactly known corners, for tests and benchmarks.
//!
//! A board is rendered through a camera with a chosen [`Lens`] (pinhole with radial distortion,
//! OpenCV's rational radial model, or a Kannala-Brandt fisheye, up to and beyond 180 degrees
//! of field of view) by area integration:
//! every pixel whose footprint may straddle a square edge is supersampled on a 12x12 grid, so
//! the image is the integral of the ideal board over the pixel to within 1/144 of a pixel's
//! area. The ideal board is then multiplied by a lighting gain field, blurred with a Gaussian
//! (optics), and Gaussian noise is added before quantization to 8 bits. The true corners are
//! the exact projections of the board corners. Pixels whose ray leaves the lens's valid range
//! (beyond a fold of the radial map, or the fisheye's largest angle) show the background.
//!
//! Conventions: board corner `(c, r)` is at `(c * square, r * square, 0)` in the board frame;
//! the square whose corners are `(c, r)` and `(c + 1, r + 1)` is dark when `c + r` is even
//! (so the cell between corners 0, 1, `cols` and `cols + 1` is dark, the crate's colour rule).
//! The board has one extra ring of squares around the inner corners and then a white margin.
//! Pixels follow OpenCV: the centre of the top-left pixel is `(0, 0)`.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// Camera and scene of a synthetic image.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Focal lengths in pixels.
    pub fx: f64,
    /// Focal length along `y` in pixels.
    pub fy: f64,
    /// Principal point `x` in pixels.
    pub cx: f64,
    /// Principal point `y` in pixels.
    pub cy: f64,
    /// Radial distortion `k1` (OpenCV model, normalized coordinates).
    pub k1: f64,
    /// Radial distortion `k2`.
    pub k2: f64,
    /// The lens; [`Lens::Radial`] (the default) uses `k1` and `k2` above.
    pub lens: Lens,
    /// Vignetting: the lighting gain is also multiplied by `1 - vignetting * (d / d_max)^2`,
    /// `d` the distance from the principal point, `d_max` that of the farthest image corner.
    pub vignetting: f64,
    /// Board-to-camera rotation as an axis-angle vector (radians).
    pub rotation: [f64; 3],
    /// Board-to-camera translation, in board units.
    pub translation: [f64; 3],
    /// Inner corners per row.
    pub cols: usize,
    /// Inner corners per column.
    pub rows: usize,
    /// Square side in board units.
    pub square: f64,
    /// Width of the white margin around the squares, in squares.
    pub margin: f64,
    /// Grey level (0..255) of the dark squares before lighting.
    pub dark: f64,
    /// Grey level of the white squares and the margin before lighting.
    pub light: f64,
    /// Background grey level (outside the board).
    pub background: f64,
    /// Lighting gain at the image's left and right edge (linear in between), and an extra
    /// vertical gradient: gain = `gain_left + (gain_right - gain_left) x / width + gain_vertical (y / height - 0.5)`.
    pub gain_left: f64,
    /// Gain at the right edge.
    pub gain_right: f64,
    /// Vertical gain slope.
    pub gain_vertical: f64,
    /// Optical blur, Gaussian standard deviation in pixels (0: none).
    pub blur: f64,
    /// Noise standard deviation in grey levels.
    pub noise: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            fx: 600.0,
            fy: 600.0,
            cx: 319.5,
            cy: 239.5,
            k1: -0.15,
            k2: 0.05,
            lens: Lens::Radial,
            vignetting: 0.0,
            rotation: [0.2, -0.3, 0.1],
            translation: [-3.5, -2.0, 14.0],
            cols: 9,
            rows: 6,
            square: 1.0,
            margin: 0.6,
            dark: 30.0,
            light: 220.0,
            background: 120.0,
            gain_left: 0.75,
            gain_right: 1.1,
            gain_vertical: 0.15,
            blur: 1.0,
            noise: 2.0,
            seed: 1,
        }
    }
}

/// A rendered image and its true corners.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// 8-bit grayscale pixels, row-major, `width * height`.
    pub pixels: Vec<u8>,
    /// True corner positions, row-major (`r * cols + c`), pixels.
    pub corners: Vec<[f64; 2]>,
}

impl Scene {
    fn rotation(&self) -> Matrix3<f64> {
        Rotation3::from_scaled_axis(Vector3::from(self.rotation)).into_inner()
    }

    /// Projects a board point `(x, y, 0)` to pixels (with distortion). `None` when the point
    /// is outside the lens's valid range (behind a pinhole camera, beyond the radial map's
    /// first fold, beyond the largest angle of a fisheye).
    pub fn project(&self, x: f64, y: f64) -> Option<[f64; 2]> {
        let p = self.rotation() * Vector3::new(x, y, 0.0) + Vector3::from(self.translation);
        let [a, b] = LensMap::new(self).distort(p)?;
        Some([self.fx * a + self.cx, self.fy * b + self.cy])
    }

    /// Renders the image.
    pub fn render(&self) -> Rendered {
        let (w, h) = (self.width, self.height);
        let rot = self.rotation();
        let t = Vector3::from(self.translation);
        let lens = LensMap::new(self);
        let normal = rot.column(2).into_owned();
        let plane_d = normal.dot(&t);
        let albedo = |u: f64, v: f64| -> f64 {
            // The pixel's ray, intersected with the board plane in front of the camera.
            let Some(ray) = lens.undistort((u - self.cx) / self.fx, (v - self.cy) / self.fy) else {
                return self.background;
            };
            let den = normal.dot(&ray);
            if den.abs() < 1e-12 {
                return self.background;
            }
            let s = plane_d / den;
            if !(s > 0.0 && s.is_finite()) {
                return self.background;
            }
            let q = rot.transpose() * (ray * s - t);
            let (bx, by) = (q.x, q.y);
            let (sx, sy) = (bx / self.square, by / self.square);
            let (lo_x, hi_x) = (-1.0 - self.margin, self.cols as f64 + self.margin);
            let (lo_y, hi_y) = (-1.0 - self.margin, self.rows as f64 + self.margin);
            if sx < lo_x || sx > hi_x || sy < lo_y || sy > hi_y {
                return self.background;
            }
            if sx < -1.0 || sx > self.cols as f64 || sy < -1.0 || sy > self.rows as f64 {
                return self.light;
            }
            let (a, b) = (sx.floor() as i64, sy.floor() as i64);
            if (a + b).rem_euclid(2) == 0 {
                self.dark
            } else {
                self.light
            }
        };
        // Albedo at pixel corners (the grid of half-integer positions) to find uniform pixels.
        let cw = w + 1;
        let corner_vals: Vec<f64> = (0..(h + 1) * cw)
            .map(|i| albedo((i % cw) as f64 - 0.5, (i / cw) as f64 - 0.5))
            .collect();
        let n = 12;
        let mut img = vec![0f64; w * h];
        for y in 0..h {
            for x in 0..w {
                let c = [
                    corner_vals[y * cw + x],
                    corner_vals[y * cw + x + 1],
                    corner_vals[(y + 1) * cw + x],
                    corner_vals[(y + 1) * cw + x + 1],
                ];
                let centre = albedo(x as f64, y as f64);
                // A pixel whose corners and centre agree, and whose neighbours' corners agree too,
                // is taken as uniform (square edges are longer than a pixel).
                let uniform = c.iter().all(|&v| v == centre) && {
                    let (x0, y0) = (x.saturating_sub(1), y.saturating_sub(1));
                    let (x1, y1) = ((x + 2).min(w), (y + 2).min(h));
                    (y0..=y1).all(|yy| (x0..=x1).all(|xx| corner_vals[yy * cw + xx] == centre))
                };
                img[y * w + x] = if uniform {
                    centre
                } else {
                    let mut s = 0.0;
                    for j in 0..n {
                        for i in 0..n {
                            s += albedo(
                                x as f64 - 0.5 + (i as f64 + 0.5) / n as f64,
                                y as f64 - 0.5 + (j as f64 + 0.5) / n as f64,
                            );
                        }
                    }
                    s / (n * n) as f64
                };
            }
        }
        // Lighting.
        let d_max2 = [
            (0.0, 0.0),
            (w as f64, 0.0),
            (0.0, h as f64),
            (w as f64, h as f64),
        ]
        .iter()
        .map(|&(x, y)| (x - 0.5 - self.cx).powi(2) + (y - 0.5 - self.cy).powi(2))
        .fold(1.0, f64::max);
        for y in 0..h {
            for x in 0..w {
                let d2 = (x as f64 - self.cx).powi(2) + (y as f64 - self.cy).powi(2);
                let g = (self.gain_left
                    + (self.gain_right - self.gain_left) * x as f64 / w as f64
                    + self.gain_vertical * (y as f64 / h as f64 - 0.5))
                    * (1.0 - self.vignetting * d2 / d_max2);
                img[y * w + x] *= g;
            }
        }
        // Optics.
        if self.blur > 0.0 {
            img = gaussian_blur(&img, w, h, self.blur);
        }
        // Noise and quantization.
        let mut rng = SplitMix(self.seed);
        let pixels = img
            .iter()
            .map(|&v| (v + self.noise * rng.normal()).round().clamp(0.0, 255.0) as u8)
            .collect();
        let corners = (0..self.rows)
            .flat_map(|r| (0..self.cols).map(move |c| (c, r)))
            .map(|(c, r)| {
                self.project(c as f64 * self.square, r as f64 * self.square)
                    .unwrap_or([f64::NAN, f64::NAN])
            })
            .collect();
        Rendered { pixels, corners }
    }
}

/// The lens of a [`Scene`]: how a ray in the camera frame becomes a normalized image point
/// (multiplied by the focal lengths and shifted by the principal point to give pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lens {
    /// Pinhole with OpenCV's radial distortion `1 + k1 r^2 + k2 r^4`, the scene's `k1`, `k2`.
    Radial,
    /// Pinhole with OpenCV's rational radial distortion
    /// `(1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)`, coefficients
    /// `[k1, k2, k3, k4, k5, k6]` (`rational8` without tangential terms; `brown-conrady5`'s
    /// radial part with `k4 = k5 = k6 = 0`). The scene's `k1`, `k2` are not used.
    Rational([f64; 6]),
    /// Kannala-Brandt fisheye (`cv2.fisheye`, `kannala-brandt4`): a ray at angle `theta` from
    /// the optical axis lands at radius `theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 +
    /// k4 theta^8)` in normalized units; all zero is the equidistant lens. Rays up to the
    /// first fold of that map, and below 180 degrees from the axis, are imaged (a field of view
    /// above 180 degrees is allowed).
    KannalaBrandt([f64; 4]),
}

/// The radial map of a [`Lens`], `rd = g(ru)` (`ru` the pinhole radius, or the angle `theta`
/// for the fisheye), with its valid range precomputed.
struct LensMap {
    fisheye: bool,
    /// [`Lens::Radial`]: undistorted by fixed-point iteration.
    radial: bool,
    /// Numerator (`k[0..3]`) and denominator (`k[3..6]`) coefficients in `ru^2`.
    k: [f64; 6],
    /// Largest `ru` imaged: the first fold of `g`, or `pi` for the fisheye.
    u_max: f64,
    /// `g(u_max)`.
    d_max: f64,
}

impl LensMap {
    fn new(scene: &Scene) -> Self {
        let (fisheye, k) = match scene.lens {
            Lens::Radial => (false, [scene.k1, scene.k2, 0.0, 0.0, 0.0, 0.0]),
            Lens::Rational(k) => (false, k),
            Lens::KannalaBrandt(k) => (true, [k[0], k[1], k[2], k[3], 0.0, 0.0]),
        };
        let mut m = Self {
            fisheye,
            radial: scene.lens == Lens::Radial,
            k,
            u_max: 0.0,
            d_max: 0.0,
        };
        // The first fold: walk out in small steps until g stops increasing.
        let limit = if fisheye {
            std::f64::consts::PI - 1e-9
        } else {
            1e3
        };
        let mut u = 0.0;
        let mut g = 0.0;
        let mut step = 1e-3;
        while u < limit {
            let next = (u + step).min(limit);
            let gn = m.g(next);
            if gn.is_nan() || gn <= g {
                break;
            }
            u = next;
            g = gn;
            if u > 1.0 {
                step = 1e-3 * u;
            }
        }
        m.u_max = u;
        m.d_max = g;
        m
    }

    fn g(&self, u: f64) -> f64 {
        let k = &self.k;
        let t = u * u;
        if self.fisheye {
            u * (1.0 + t * (k[0] + t * (k[1] + t * (k[2] + t * k[3]))))
        } else {
            let num = 1.0 + t * (k[0] + t * (k[1] + t * k[2]));
            let den = 1.0 + t * (k[3] + t * (k[4] + t * k[5]));
            u * num / den
        }
    }

    /// Derivative of [`LensMap::g`].
    fn dg(&self, u: f64) -> f64 {
        let k = &self.k;
        let t = u * u;
        if self.fisheye {
            1.0 + t * (3.0 * k[0] + t * (5.0 * k[1] + t * (7.0 * k[2] + t * 9.0 * k[3])))
        } else {
            let num = 1.0 + t * (k[0] + t * (k[1] + t * k[2]));
            let den = 1.0 + t * (k[3] + t * (k[4] + t * k[5]));
            let dnum = k[0] + t * (2.0 * k[1] + t * 3.0 * k[2]);
            let dden = k[3] + t * (2.0 * k[4] + t * 3.0 * k[5]);
            num / den + 2.0 * t * (dnum * den - num * dden) / (den * den)
        }
    }

    /// Normalized distorted point of a camera-frame point.
    fn distort(&self, p: Vector3<f64>) -> Option<[f64; 2]> {
        let rxy = p.x.hypot(p.y);
        let u = if self.fisheye {
            rxy.atan2(p.z)
        } else {
            if p.z <= 1e-9 {
                return None;
            }
            rxy / p.z
        };
        if u > self.u_max {
            return None;
        }
        if rxy < 1e-300 {
            return Some([0.0, 0.0]);
        }
        let d = self.g(u) / rxy;
        Some([p.x * d, p.y * d])
    }

    /// Ray direction of a normalized distorted point; `None` outside the imaged range.
    fn undistort(&self, xd: f64, yd: f64) -> Option<Vector3<f64>> {
        let rd = xd.hypot(yd);
        if rd >= self.d_max {
            return None;
        }
        if rd < 1e-300 {
            return Some(Vector3::new(0.0, 0.0, 1.0));
        }
        if self.radial {
            // Mild radial distortion: the fixed-point iteration (fast, and the images of
            // `Lens::Radial` scenes stay what they were before the other lenses).
            let (k1, k2) = (self.k[0], self.k[1]);
            let (mut x, mut y) = (xd, yd);
            for _ in 0..10 {
                let r2 = x * x + y * y;
                let d = 1.0 + k1 * r2 + k2 * r2 * r2;
                x = xd / d;
                y = yd / d;
            }
            return Some(Vector3::new(x, y, 1.0));
        }
        // g is increasing on [0, u_max]: safeguarded Newton (bisection bracket).
        let (mut lo, mut hi) = (0.0, self.u_max);
        let mut u = rd.min(self.u_max);
        for _ in 0..60 {
            let f = self.g(u) - rd;
            if f > 0.0 {
                hi = u;
            } else {
                lo = u;
            }
            let df = self.dg(u);
            let mut next = u - f / df;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - u).abs() < 1e-13 * u.max(1e-3) {
                u = next;
                break;
            }
            u = next;
        }
        let (cx, cy) = (xd / rd, yd / rd);
        Some(if self.fisheye {
            let (s, c) = u.sin_cos();
            Vector3::new(s * cx, s * cy, c)
        } else {
            Vector3::new(u * cx, u * cy, 1.0)
        })
    }
}

fn gaussian_blur(img: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let r = (4.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    let k: Vec<f64> = k.iter().map(|v| v / s).collect();
    let mut tmp = vec![0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let xx = (x as isize + i as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * img[y * w + xx];
            }
            tmp[y * w + x] = acc;
        }
    }
    let mut out = vec![0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for (i, kv) in k.iter().enumerate() {
                let yy = (y as isize + i as isize - r).clamp(0, h as isize - 1) as usize;
                acc += kv * tmp[yy * w + x];
            }
            out[y * w + x] = acc;
        }
    }
    out
}

/// SplitMix64 with Box-Muller normals: small, deterministic, no dependency.
pub(crate) struct SplitMix(pub(crate) u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    pub(crate) fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}
