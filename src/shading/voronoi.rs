//! Blender's Voronoi Texture (Worley 1996 cellular noise with one jittered feature point per
//! unit cell), with Blender's features (F1, F2, Smooth F1 after Quilez's smooth Voronoi,
//! Distance to Edge after Quilez's exact cell borders, N-Sphere Radius), metrics and fractal
//! octaves, in 1 to 4 dimensions. The feature points are placed by the same hashes as Cycles
//! (PCG of the integer cell in 2D-4D, lookup3 of the float cell in 1D; `noise`), so cells
//! land where Cycles puts them.
//!
//! Points are `[f32; 4]` with `dims` components used; neighbour cells are visited in Cycles'
//! order (x fastest), which decides ties and the order of smooth blending.

use glam::{Vec3, Vec4};

use super::noise::{hash_float, hash_float_to_vec3, pcg2d, pcg3d, pcg4d, pcg_unit};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    F1,
    F2,
    SmoothF1,
    DistanceToEdge,
    NSphereRadius,
}

pub const FEATURES: &[(&str, Feature)] = &[
    ("f1", Feature::F1),
    ("f2", Feature::F2),
    ("smooth_f1", Feature::SmoothF1),
    ("distance_to_edge", Feature::DistanceToEdge),
    ("n_sphere_radius", Feature::NSphereRadius),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    Euclidean,
    Manhattan,
    Chebychev,
    Minkowski,
}

pub const METRICS: &[(&str, Metric)] = &[
    ("euclidean", Metric::Euclidean),
    ("manhattan", Metric::Manhattan),
    ("chebychev", Metric::Chebychev),
    ("minkowski", Metric::Minkowski),
];

/// The node's settings and inputs (after the node's clamping, see [`VoronoiParams::new`]).
#[derive(Clone, Copy, Debug)]
pub struct VoronoiParams {
    pub dims: usize,
    pub feature: Feature,
    pub metric: Metric,
    pub normalize: bool,
    pub scale: f32,
    pub detail: f32,
    pub roughness: f32,
    pub lacunarity: f32,
    pub smoothness: f32,
    pub exponent: f32,
    pub randomness: f32,
    max_distance: f32,
}

/// The node's outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoronoiOutput {
    pub distance: f32,
    pub color: Vec3,
    pub position: Vec4,
    pub radius: f32,
}

type P = [f32; 4];

fn pcg3(i: [i32; 4]) -> P {
    let h = pcg3d([i[0], i[1], i[2]]);
    [pcg_unit(h[0]), pcg_unit(h[1]), pcg_unit(h[2]), 0.0]
}

fn add(a: P, b: P) -> P {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}
fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]
}
fn scale(a: P, s: f32) -> P {
    [a[0] * s, a[1] * s, a[2] * s, a[3] * s]
}
fn dot(a: P, b: P, n: usize) -> f32 {
    (0..n).map(|i| a[i] * b[i]).sum()
}
fn lerp_p(a: P, b: P, t: f32) -> P {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
        a[3] + (b[3] - a[3]) * t,
    ]
}

impl VoronoiParams {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        dims: usize,
        feature: Feature,
        metric: Metric,
        normalize: bool,
        scale: f32,
        detail: f32,
        roughness: f32,
        lacunarity: f32,
        smoothness: f32,
        exponent: f32,
        randomness: f32,
    ) -> Self {
        let mut p = VoronoiParams {
            dims: dims.clamp(1, 4),
            feature,
            metric,
            normalize,
            scale,
            detail: detail.clamp(0.0, 15.0),
            roughness: roughness.clamp(0.0, 1.0),
            lacunarity,
            smoothness: (smoothness / 2.0).clamp(0.0, 0.5),
            exponent,
            randomness: randomness.clamp(0.0, 1.0),
            max_distance: 0.0,
        };
        let half = 0.5 + 0.5 * p.randomness;
        p.max_distance = match feature {
            Feature::DistanceToEdge => half,
            _ => {
                let corner = [half; 4];
                let d = if p.dims == 1 {
                    half
                } else {
                    p.distance([0.0; 4], corner)
                };
                d * if feature == Feature::F2 { 2.0 } else { 1.0 }
            }
        };
        p
    }

    fn distance(&self, a: P, b: P) -> f32 {
        let n = self.dims;
        let d = &sub(a, b).map(f32::abs)[..n];
        if n == 1 {
            return d[0];
        }
        match self.metric {
            Metric::Euclidean => d.iter().map(|x| x * x).sum::<f32>().sqrt(),
            Metric::Manhattan => d.iter().sum(),
            Metric::Chebychev => d.iter().cloned().fold(0.0, f32::max),
            Metric::Minkowski => d
                .iter()
                .map(|x| x.powf(self.exponent))
                .sum::<f32>()
                .powf(1.0 / self.exponent),
        }
    }

    /// The jitter of the feature point of cell `c` (integral coordinates), in [0, 1] per axis.
    fn jitter(&self, c: P) -> P {
        let i = c.map(|x| x as i32);
        match self.dims {
            1 => [hash_float(c[0]), 0.0, 0.0, 0.0],
            2 => {
                let h = pcg2d([i[0], i[1]]);
                [pcg_unit(h[0]), pcg_unit(h[1]), 0.0, 0.0]
            }
            3 => pcg3(i),
            _ => pcg4d(i).map(pcg_unit),
        }
    }

    fn cell_color(&self, c: P) -> Vec3 {
        let i = c.map(|x| x as i32);
        let v = match self.dims {
            1 => return hash_float_to_vec3(c[0]),
            2 => pcg3([i[0], i[1], 0, 0]),
            3 => pcg3(i),
            _ => pcg4d(i).map(pcg_unit),
        };
        Vec3::new(v[0], v[1], v[2])
    }

    /// The position output of a point (1D: in w, as Blender's `voronoi_position`).
    fn position(&self, p: P) -> Vec4 {
        match self.dims {
            1 => Vec4::new(0.0, 0.0, 0.0, p[0]),
            2 => Vec4::new(p[0], p[1], 0.0, 0.0),
            3 => Vec4::new(p[0], p[1], p[2], 0.0),
            _ => Vec4::from_array(p),
        }
    }

    /// Neighbour cell offsets within `r`, x fastest.
    fn offsets(&self, r: i32) -> impl Iterator<Item = P> + '_ {
        let m = 2 * r + 1;
        let n = self.dims as u32;
        (0..m.pow(n)).map(move |t| {
            let mut o = [0.0; 4];
            let mut t = t;
            for item in o.iter_mut().take(n as usize) {
                *item = (t % m - r) as f32;
                t /= m;
            }
            o
        })
    }

    fn point(&self, cell: P, offset: P) -> P {
        add(
            offset,
            scale(self.jitter(add(cell, offset)), self.randomness),
        )
    }

    fn split(&self, coord: P) -> (P, P) {
        let mut cell = [0.0; 4];
        for (i, c) in cell.iter_mut().enumerate().take(self.dims) {
            *c = coord[i].floor();
        }
        (cell, sub(coord, cell))
    }

    fn f1(&self, coord: P) -> VoronoiOutput {
        let (cell, local) = self.split(coord);
        let (mut best, mut off, mut pos) = (f32::MAX, [0.0; 4], [0.0; 4]);
        for o in self.offsets(1) {
            let p = self.point(cell, o);
            let d = self.distance(p, local);
            if d < best {
                best = d;
                off = o;
                pos = p;
            }
        }
        VoronoiOutput {
            distance: best,
            color: self.cell_color(add(cell, off)),
            position: self.position(add(pos, cell)),
            radius: 0.0,
        }
    }

    fn f2(&self, coord: P) -> VoronoiOutput {
        let (cell, local) = self.split(coord);
        let (mut d1, mut d2) = (f32::MAX, f32::MAX);
        let (mut o1, mut o2, mut p1, mut p2) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
        for o in self.offsets(1) {
            let p = self.point(cell, o);
            let d = self.distance(p, local);
            if d < d1 {
                (d2, o2, p2) = (d1, o1, p1);
                (d1, o1, p1) = (d, o, p);
            } else if d < d2 {
                (d2, o2, p2) = (d, o, p);
            }
        }
        VoronoiOutput {
            distance: d2,
            color: self.cell_color(add(cell, o2)),
            position: self.position(add(p2, cell)),
            radius: 0.0,
        }
    }

    fn smooth_f1(&self, coord: P) -> VoronoiOutput {
        let (cell, local) = self.split(coord);
        let (mut dist, mut color, mut pos) = (0.0f32, Vec3::ZERO, [0.0f32; 4]);
        let mut h = -1.0f32;
        let s = self.smoothness;
        for o in self.offsets(2) {
            let p = self.point(cell, o);
            let d = self.distance(p, local);
            h = if h == -1.0 {
                1.0
            } else {
                super::math_ops::smoothstep(0.0, 1.0, 0.5 + 0.5 * (dist - d) / s)
            };
            let mut correction = s * h * (1.0 - h);
            dist = dist + (d - dist) * h - correction;
            correction /= 1.0 + 3.0 * s;
            color = color.lerp(self.cell_color(add(cell, o)), h) - Vec3::splat(correction);
            let c = [correction; 4];
            pos = sub(lerp_p(pos, p, h), c);
        }
        VoronoiOutput {
            distance: dist,
            color,
            position: self.position(add(cell, pos)),
            radius: 0.0,
        }
    }

    fn distance_to_edge(&self, coord: P) -> f32 {
        let (cell, local) = self.split(coord);
        if self.dims == 1 {
            let r = self.randomness;
            let mid = hash_float(cell[0]) * r;
            let left = -1.0 + hash_float(cell[0] - 1.0) * r;
            let right = 1.0 + hash_float(cell[0] + 1.0) * r;
            let l = ((mid + left) / 2.0 - local[0]).abs();
            let rr = ((mid + right) / 2.0 - local[0]).abs();
            return l.min(rr);
        }
        let n = self.dims;
        let (mut closest, mut best) = ([0.0; 4], f32::MAX);
        for o in self.offsets(1) {
            let v = sub(self.point(cell, o), local);
            let d = dot(v, v, n);
            if d < best {
                best = d;
                closest = v;
            }
        }
        let mut best = f32::MAX;
        for o in self.offsets(1) {
            let v = sub(self.point(cell, o), local);
            let perp = sub(v, closest);
            let len2 = dot(perp, perp, n);
            if len2 > 0.0001 {
                let mid = scale(add(closest, v), 0.5);
                best = best.min(dot(mid, scale(perp, 1.0 / len2.sqrt()), n));
            }
        }
        best
    }

    fn n_sphere_radius(&self, coord: P) -> f32 {
        let (cell, local) = self.split(coord);
        let n = self.dims;
        let euclid = |a: P, b: P| {
            let d = sub(a, b);
            dot(d, d, n).sqrt()
        };
        let (mut closest, mut closest_off, mut best) = ([0.0; 4], [0.0; 4], f32::MAX);
        for o in self.offsets(1) {
            let p = self.point(cell, o);
            let d = euclid(p, local);
            if d < best {
                best = d;
                closest = p;
                closest_off = o;
            }
        }
        let (mut best, mut other) = (f32::MAX, [0.0; 4]);
        for o in self.offsets(1) {
            if o == [0.0; 4] {
                continue;
            }
            let off = add(o, closest_off);
            let p = self.point(cell, off);
            let d = euclid(closest, p);
            if d < best {
                best = d;
                other = p;
            }
        }
        euclid(other, closest) / 2.0
    }

    fn octave(&self, coord: P) -> VoronoiOutput {
        match self.feature {
            Feature::F2 => self.f2(coord),
            Feature::SmoothF1 if self.smoothness != 0.0 => self.smooth_f1(coord),
            _ => self.f1(coord),
        }
    }

    /// The node's outputs at `p` (vector) and `w`, before the node's Scale.
    pub fn eval(&self, p: Vec3, w: f32) -> VoronoiOutput {
        let coord = match self.dims {
            1 => [w * self.scale, 0.0, 0.0, 0.0],
            _ => {
                let q = p * self.scale;
                [q.x, q.y, q.z, w * self.scale]
            }
        };
        let zero_input = self.detail == 0.0 || self.roughness == 0.0;
        let octaves = self.detail.ceil() as i32;
        let remainder = self.detail - self.detail.floor();
        match self.feature {
            Feature::NSphereRadius => VoronoiOutput {
                radius: self.n_sphere_radius(coord),
                ..Default::default()
            },
            Feature::DistanceToEdge => {
                let (mut amp, mut max_amp, mut sc, mut dist) =
                    (1.0f32, self.max_distance, 1.0f32, 8.0f32);
                for i in 0..=octaves {
                    let d = self.distance_to_edge(scale(coord, sc));
                    if zero_input {
                        dist = d;
                        break;
                    }
                    if i as f32 <= self.detail {
                        max_amp += (self.max_distance / sc - max_amp) * amp;
                        dist += (dist.min(d / sc) - dist) * amp;
                        sc *= self.lacunarity;
                        amp *= self.roughness;
                    } else if remainder != 0.0 {
                        let lerp_amp = max_amp + (self.max_distance / sc - max_amp) * amp;
                        max_amp += (lerp_amp - max_amp) * remainder;
                        let lerp_dist = dist + (dist.min(d / sc) - dist) * amp;
                        dist += (dist.min(lerp_dist) - dist) * remainder;
                    }
                }
                if self.normalize {
                    dist /= max_amp;
                }
                VoronoiOutput {
                    distance: dist,
                    ..Default::default()
                }
            }
            _ => {
                let (mut amp, mut max_amp, mut sc) = (1.0f32, 0.0f32, 1.0f32);
                let mut out = VoronoiOutput::default();
                for i in 0..=octaves {
                    let o = self.octave(scale(coord, sc));
                    if zero_input {
                        max_amp = 1.0;
                        out = o;
                        break;
                    }
                    if i as f32 <= self.detail {
                        max_amp += amp;
                        out.distance += o.distance * amp;
                        out.color += o.color * amp;
                        out.position = out.position.lerp(o.position / sc, amp);
                        sc *= self.lacunarity;
                        amp *= self.roughness;
                    } else if remainder != 0.0 {
                        max_amp += amp * remainder;
                        out.distance += o.distance * amp * remainder;
                        out.color += o.color * amp * remainder;
                        let moved = out.position.lerp(o.position / sc, amp);
                        out.position = out.position.lerp(moved, remainder);
                    }
                }
                if self.normalize {
                    out.distance /= max_amp * self.max_distance;
                    out.color /= max_amp;
                }
                if self.scale != 0.0 {
                    out.position /= self.scale;
                } else {
                    out.position = Vec4::ZERO;
                }
                out
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(dims: usize, feature: Feature, metric: Metric) -> VoronoiParams {
        VoronoiParams::new(
            dims, feature, metric, false, 1.0, 0.0, 0.5, 2.0, 1.0, 0.5, 1.0,
        )
    }

    #[test]
    fn f1_is_the_distance_to_the_nearest_feature_point() {
        let p = params(3, Feature::F1, Metric::Euclidean);
        let q = Vec3::new(2.3, -1.7, 0.4);
        let out = p.eval(q, 0.0);
        // The position output is that feature point.
        let fp = out.position.truncate();
        assert!((fp.distance(q) - out.distance).abs() < 1e-5);
        // No feature point of the 5x5x5 neighbourhood is nearer.
        let c = q.floor();
        for t in 0..125 {
            let o = Vec3::new(
                (t % 5 - 2) as f32,
                ((t / 5) % 5 - 2) as f32,
                (t / 25 - 2) as f32,
            );
            let cell = [c.x + o.x, c.y + o.y, c.z + o.z, 0.0];
            let j = p.jitter(cell);
            let pt = c + o + Vec3::new(j[0], j[1], j[2]);
            assert!(pt.distance(q) >= out.distance - 1e-5);
        }
        let f2 = params(3, Feature::F2, Metric::Euclidean).eval(q, 0.0);
        assert!(f2.distance >= out.distance);
    }

    #[test]
    fn metrics_order_and_edges() {
        let q = Vec3::new(0.3, 0.8, 0.1);
        let e = params(3, Feature::F1, Metric::Euclidean)
            .eval(q, 0.0)
            .distance;
        let m = params(3, Feature::F1, Metric::Manhattan)
            .eval(q, 0.0)
            .distance;
        let c = params(3, Feature::F1, Metric::Chebychev)
            .eval(q, 0.0)
            .distance;
        assert!(c <= e + 1e-6 && e <= m + 1e-6, "{c} {e} {m}");
        let edge = params(2, Feature::DistanceToEdge, Metric::Euclidean)
            .eval(q, 0.0)
            .distance;
        assert!((0.0..1.0).contains(&edge));
        let r = params(3, Feature::NSphereRadius, Metric::Euclidean)
            .eval(q, 0.0)
            .radius;
        assert!(r > 0.0 && r < 1.5);
        for dims in 1..=4 {
            for (_, f) in FEATURES {
                let o = params(dims, *f, Metric::Euclidean).eval(q, 0.7);
                assert!(o.distance.is_finite() && o.color.is_finite() && o.radius.is_finite());
            }
        }
    }
}
