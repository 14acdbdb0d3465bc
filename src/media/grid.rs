//! Majorant grids for heterogeneous volumes: the largest density of each cell of a coarse grid
//! over the object's bounding box, so delta and ratio tracking take tentative steps at the
//! local bound instead of the global one (empty space costs nothing, thin wisps little). The
//! piecewise-constant majorant along a ray comes from a 3D DDA (Amanatides & Woo 1987), as
//! pbrt-v4's `DDAMajorantIterator`.

use glam::{Affine3A, Vec3};

/// Cells per axis.
pub const GRID_RES: usize = 16;

/// Density bounds over an object-space box, `GRID_RES`^3 cells (x fastest).
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    lo: Vec3,
    hi: Vec3,
    cells: Vec<f32>,
}

impl MajorantGrid {
    /// A grid over [lo, hi] from per-cell maxima of sampled densities, times `margin`.
    ///
    /// Taking the maximum over each cell's 26 neighbours as well (a safer bound against peaks
    /// between the samples) cost a noise-textured cloud 1.45x the instructions (callgrind, 40x40
    /// px, 64 spp) and changed its mean by 0.04% (256 spp): the margin alone is kept.
    pub fn from_samples(lo: Vec3, hi: Vec3, sampled_max: &[f32], margin: f32) -> Self {
        let cells = sampled_max.iter().map(|m| m * margin).collect();
        MajorantGrid { lo, hi, cells }
    }

    /// The object-space centre of cell (x, y, z) offset by `u` in [0,1)^3 within it.
    pub fn cell_point(lo: Vec3, hi: Vec3, cell: usize, u: Vec3) -> Vec3 {
        let (x, y, z) = (
            cell % GRID_RES,
            (cell / GRID_RES) % GRID_RES,
            cell / (GRID_RES * GRID_RES),
        );
        let f = (Vec3::new(x as f32, y as f32, z as f32) + u) / GRID_RES as f32;
        lo + (hi - lo) * f
    }

    pub fn max(&self) -> f32 {
        self.cells.iter().copied().fold(0.0, f32::max)
    }

    /// The runs of constant bound along the world ray `origin + t dir` for t in [0, t_end),
    /// through the object whose inverse transform is `world_to_object`. Outside the box the
    /// bound is 0 (the volume's mesh lies inside its box).
    pub fn runs(
        &self,
        world_to_object: &Affine3A,
        origin: Vec3,
        dir: Vec3,
        t_end: f32,
    ) -> MajorantRuns<'_> {
        // An affine map keeps the ray parameter: o' + t d' is the object-space point at t.
        let o = world_to_object.transform_point3(origin);
        let d = world_to_object.transform_vector3(dir);
        let extent = (self.hi - self.lo).max(Vec3::splat(1e-30));
        // Grid coordinates: cell units.
        let g_o = (o - self.lo) / extent * GRID_RES as f32;
        let g_d = d / extent * GRID_RES as f32;
        // Clip [0, t_end) to the box [0, RES]^3.
        let (mut t0, mut t1) = (0.0f32, t_end);
        for a in 0..3 {
            if g_d[a].abs() < 1e-30 {
                if g_o[a] < 0.0 || g_o[a] > GRID_RES as f32 {
                    t1 = -1.0;
                }
                continue;
            }
            let inv = 1.0 / g_d[a];
            let (mut ta, mut tb) = (-g_o[a] * inv, (GRID_RES as f32 - g_o[a]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        let inside = t0 < t1;
        let p = g_o + g_d * t0;
        let cell = [0, 1, 2].map(|a| (p[a].floor() as i32).clamp(0, GRID_RES as i32 - 1));
        let step = [0, 1, 2].map(|a| if g_d[a] >= 0.0 { 1 } else { -1 });
        let next = [0, 1, 2].map(|a| {
            if g_d[a].abs() < 1e-30 {
                f32::INFINITY
            } else {
                let boundary = (cell[a] + if step[a] > 0 { 1 } else { 0 }) as f32;
                (boundary - g_o[a]) / g_d[a]
            }
        });
        let delta = [0, 1, 2].map(|a| {
            if g_d[a].abs() < 1e-30 {
                f32::INFINITY
            } else {
                1.0 / g_d[a].abs()
            }
        });
        MajorantRuns {
            grid: self,
            t: 0.0,
            t_enter: if inside { t0 } else { t_end },
            t_exit: if inside { t1 } else { t_end },
            t_end,
            cell,
            step,
            next,
            delta,
        }
    }

    fn at(&self, cell: [i32; 3]) -> f32 {
        let n = GRID_RES as i32;
        self.cells[(cell[0] + n * (cell[1] + n * cell[2])) as usize]
    }
}

/// Iterator over `(t0, t1, bound)` runs covering [0, t_end) (see [`MajorantGrid::runs`]).
pub struct MajorantRuns<'g> {
    grid: &'g MajorantGrid,
    t: f32,
    t_enter: f32,
    t_exit: f32,
    t_end: f32,
    cell: [i32; 3],
    step: [i32; 3],
    next: [f32; 3],
    delta: [f32; 3],
}

impl Iterator for MajorantRuns<'_> {
    type Item = (f32, f32, f32);

    fn next(&mut self) -> Option<(f32, f32, f32)> {
        if !(self.t < self.t_end) {
            return None;
        }
        if self.t < self.t_enter {
            // Before the box: no density.
            let run = (self.t, self.t_enter, 0.0);
            self.t = self.t_enter;
            return Some(run);
        }
        if self.t >= self.t_exit {
            let run = (self.t, self.t_end, 0.0);
            self.t = self.t_end;
            return Some(run);
        }
        // The axis whose boundary comes first ends this cell's run.
        let a = if self.next[0] < self.next[1] {
            if self.next[0] < self.next[2] {
                0
            } else {
                2
            }
        } else if self.next[1] < self.next[2] {
            1
        } else {
            2
        };
        let end = self.next[a].min(self.t_exit).max(self.t);
        let run = (self.t, end, self.grid.at(self.cell));
        self.t = end;
        self.cell[a] += self.step[a];
        self.next[a] += self.delta[a];
        if !(0..GRID_RES as i32).contains(&self.cell[a]) {
            self.t_exit = self.t_exit.min(self.t);
        }
        Some(run)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_cover_the_ray_and_bound_each_cell() {
        // A density that rises along x: cell bounds follow it.
        let n = GRID_RES;
        let sampled: Vec<f32> = (0..n * n * n).map(|i| (i % n) as f32).collect();
        let grid = MajorantGrid::from_samples(Vec3::splat(-1.0), Vec3::splat(1.0), &sampled, 1.0);
        let m = Affine3A::from_scale(Vec3::splat(0.5)); // world = 2 x object
        let origin = Vec3::new(-3.0, 0.1, 0.2);
        let dir = Vec3::new(1.0, 0.05, -0.02).normalize();
        let runs: Vec<_> = grid.runs(&m, origin, dir, 8.0).collect();
        // Contiguous from 0 to t_end.
        assert_eq!(runs[0].0, 0.0);
        assert_eq!(runs.last().unwrap().1, 8.0);
        for w in runs.windows(2) {
            assert!((w[0].1 - w[1].0).abs() < 1e-5, "{runs:?}");
        }
        // Every point's bound is the density of its cell (x cell index).
        for &(t0, t1, bound) in &runs {
            let t = 0.5 * (t0 + t1);
            let p = m.transform_point3(origin + dir * t);
            let inside = p.abs().max_element() <= 1.0;
            if inside {
                let cx = (((p.x + 1.0) / 2.0 * n as f32) as usize).min(n - 1);
                assert_eq!(bound, cx as f32, "t {t}");
            } else {
                assert_eq!(bound, 0.0, "outside the box at t {t}");
            }
        }
        // A ray missing the box: one empty run.
        let miss: Vec<_> = grid
            .runs(&m, Vec3::new(0.0, 5.0, 0.0), Vec3::X, 3.0)
            .collect();
        assert_eq!(miss, vec![(0.0, 3.0, 0.0)]);
    }
}
