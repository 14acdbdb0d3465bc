//! Triangle geometry and ray intersection: one compressed wide BVH (obvhs CWBVH) per mesh
//! (bottom level) and one over the instances (top level), so a mesh placed by several glTF
//! nodes is stored once.

pub mod bvh_cache;
pub mod motion;
pub mod shapes;
mod traversal;
mod triangle;
pub mod wide_bvh;

pub use motion::MotionTransform;
pub use triangle::{intersect_triangle, ray_plane_barycentrics};

use glam::{Affine3A, Mat3, Vec2, Vec3, Vec3A, Vec4};
use obvhs::{aabb::Aabb, cwbvh::CwBvh, ray::Ray as BvhRay, BvhBuildParams};
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::Arc;

/// A ray with an (unnormalised allowed) direction and a parametric extent [0, t_max), at a
/// normalised shutter time (0 = open, 1 = closed) that places moving instances
/// (`motion`); every ray of a camera path carries the path's time.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub time: f32,
}

impl Ray {
    /// A ray at shutter time 0.5 (the only time a scene without motion has).
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin,
            dir,
            time: 0.5,
        }
    }
    /// A ray at shutter time `time`.
    pub fn new_at(origin: Vec3, dir: Vec3, time: f32) -> Self {
        Ray { origin, dir, time }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Object-space triangle mesh with its bottom-level BVH. Triangles are stored in BVH leaf
/// order, so the traversal's primitive id indexes `tris` and `indices` directly.
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Per-vertex tangents (xyz unit, w = bitangent sign; zero = unusable), from glTF
    /// `TANGENT`. Only normal mapping reads them.
    pub tangents: Option<Vec<Vec4>>,
    /// TEXCOORD_1.. and COLOR_0.. per vertex, for shading graphs (`MeshDesc`'s).
    pub extra_uvs: Vec<Option<Vec<Vec2>>>,
    pub colors: Vec<Option<Vec<Vec4>>>,
    pub indices: Vec<[u32; 3]>,
    /// Runtime material id (index into the scene's material list).
    pub material: u32,
    tris: Vec<TriangleEdges>,
    /// The mesh's own BVH, for meshes that several instances share (`Geometry` traces the
    /// others in its flattened level): None until `Geometry::new` needs it.
    bvh: Option<CwBvh>,
    bounds: Aabb,
    /// Deformation motion blur: the vertices over the shutter (None: a rigid mesh).
    deformation: Option<Arc<Deformation>>,
}

/// A deforming mesh's vertex positions (and shading normals) at `keys()` equally spaced times
/// over the shutter, linearly interpolated between them (Cycles interpolates its deformation
/// keys linearly too). Triangles are traced at the ray's time inside a BVH over the boxes they
/// sweep; what is not traced at a time (light sampling's triangle areas) uses the mesh at its
/// current frame (`Mesh::positions`).
#[derive(Debug)]
pub struct Deformation {
    positions: Vec<Vec<Vec3>>,
    normals: Option<Vec<Vec<Vec3>>>,
    /// The mesh's box at its current frame: its texture space (Generated coordinates), which
    /// motion blur must not move (`Mesh::aabb` is the swept box).
    texture_space: Aabb,
}

impl Deformation {
    /// The keys around shutter time `time` in [0, 1] and the weight of the later one.
    #[inline]
    fn at(&self, time: f32) -> (usize, usize, f32) {
        let last = self.positions.len() - 1;
        let x = time.clamp(0.0, 1.0) * last as f32;
        let k = (x as usize).min(last - 1);
        (k, k + 1, x - k as f32)
    }

    #[inline]
    fn position(&self, v: usize, time: f32) -> Vec3 {
        let (a, b, f) = self.at(time);
        self.positions[a][v].lerp(self.positions[b][v], f)
    }

    #[inline]
    fn normal(&self, v: usize, time: f32) -> Option<Vec3> {
        let (a, b, f) = self.at(time);
        self.normals.as_ref().map(|n| n[a][v].lerp(n[b][v], f))
    }
}

/// Vertex + two edges: what the Möller–Trumbore test needs, packed together for locality.
/// Plain bytes (three `Vec3`, no padding), so the flattened level keys its BVH cache entry on
/// them in place.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct TriangleEdges {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

// SAFETY: repr(C) of three glam Vec3 (each Pod, 12 bytes, align 4): no padding, every bit
// pattern valid.
unsafe impl bytemuck::Zeroable for TriangleEdges {}
unsafe impl bytemuck::Pod for TriangleEdges {}
const _: () = assert!(std::mem::size_of::<TriangleEdges>() == 36);

impl obvhs::Boundable for TriangleEdges {
    fn aabb(&self) -> Aabb {
        let v0 = Vec3A::from(self.v0);
        let v1 = Vec3A::from(self.v0 + self.e1);
        let v2 = Vec3A::from(self.v0 + self.e2);
        Aabb::new(v0.min(v1).min(v2), v0.max(v1).max(v2))
    }
}

/// A traversal ray for obvhs. Negative zeros in the direction become +0: obvhs gives -0.0 a
/// negative inverse (-inf) while its node-order logic treats the component as positive, and
/// such rays (exact axis-aligned directions: orthographic cameras, mirror reflections off
/// axis-aligned faces) then miss geometry. Adding +0.0 maps -0.0 to +0.0 and nothing else.
#[inline]
fn bvh_ray(origin: Vec3, dir: Vec3, t_max: f32) -> BvhRay {
    BvhRay::new(origin.into(), (dir + Vec3::ZERO).into(), 0.0, t_max)
}

/// Triangle count from which a mesh's BVH is built with obvhs' fastest preset.
const LARGE_MESH_TRIANGLES: usize = 50_000;

/// BVH build quality. Large meshes use obvhs' very-fast preset (PLOC with the minimum search
/// radius): on the 160k-triangle bench mesh it builds in 65-74 ms instead of 100-103 ms with
/// closest-hit and shadow traversal no slower (`cargo bench --bench bvh`), and the build is
/// the largest part of the Blender round trip's overhead. Smaller meshes build in a few ms
/// either way and keep the medium preset.
fn build_params(triangles: usize) -> BvhBuildParams {
    if triangles >= LARGE_MESH_TRIANGLES {
        BvhBuildParams::very_fast_build()
    } else {
        BvhBuildParams::medium_build()
    }
}

/// A BVH over `tris` from the on-disk cache when it is enabled and holds the BVH of these
/// exact key bytes (`bvh_cache`), else built (and stored when the cache is enabled). Meshes
/// key their own positions and indices in place (no copy): the triangles are a function of
/// them, and for meshes that share vertices they are half the bytes.
fn cached_or_built_bvh(tris: &[TriangleEdges], key_parts: &[&[u8]]) -> CwBvh {
    let large = tris.len() >= LARGE_MESH_TRIANGLES;
    let key = bvh_cache::enabled().then(|| bvh_cache::key(key_parts, large as u8));
    if let Some(bvh) = key.and_then(|k| bvh_cache::load(k, tris.len())) {
        return bvh;
    }
    let bvh = wide_bvh::build(tris, build_params(tris.len()));
    if let Some(k) = key {
        bvh_cache::store(k, tris.len(), &bvh);
    }
    bvh
}

/// `items` (one per BVH primitive) in the BVH's leaf order, so that the traversal's primitive
/// ids index them directly.
fn leaf_order<T: Copy + Send + Sync>(bvh: &CwBvh, items: &[T]) -> Vec<T> {
    bvh.primitive_indices
        .par_iter()
        .map(|&i| items[i as usize])
        .collect()
}

impl Mesh {
    /// Builds the mesh and its BVH. Triangles must already be non-degenerate with valid indices
    /// (the scene loader guarantees it); `material` is the runtime material id.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
        material: u32,
    ) -> Self {
        let mut mesh = Self::without_bvh(positions, normals, uvs, indices, material);
        mesh.ensure_bvh();
        mesh
    }

    /// The mesh without its own BVH, for a mesh that only one instance uses: `Geometry` puts
    /// its triangles in the flattened level (and builds the BVH only if an instance needs it).
    pub fn without_bvh(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
        material: u32,
    ) -> Self {
        // These per-triangle passes are a few ms each for 100k triangles: parallel like the
        // BVH build after them.
        let tris: Vec<TriangleEdges> = indices
            .par_iter()
            .map(|&[a, b, c]| {
                let v0 = positions[a as usize];
                TriangleEdges {
                    v0,
                    e1: positions[b as usize] - v0,
                    e2: positions[c as usize] - v0,
                }
            })
            .collect();
        let bounds = tris
            .par_iter()
            .map(obvhs::Boundable::aabb)
            .reduce(Aabb::empty, |a, b| a.union(&b));
        Mesh {
            positions,
            normals,
            uvs,
            tangents: None,
            extra_uvs: Vec::new(),
            colors: Vec::new(),
            indices,
            material,
            tris,
            bvh: None,
            bounds,
            deformation: None,
        }
    }

    /// Gives the mesh deformation motion blur: `positions` (and `normals`) per key, at least
    /// two keys of one entry per vertex each (else ignored: the mesh stays rigid). The bounds
    /// grow to everything the mesh sweeps.
    pub fn with_deformation(
        mut self,
        positions: Vec<Vec<Vec3>>,
        normals: Option<Vec<Vec<Vec3>>>,
    ) -> Self {
        let n = self.positions.len();
        if positions.len() < 2 || positions.iter().any(|k| k.len() != n) {
            return self;
        }
        let normals = normals.filter(|keys| {
            keys.len() == positions.len()
                && keys.iter().all(|k| k.len() == n)
                && self.normals.is_some()
        });
        let texture_space = self.bounds;
        for key in &positions {
            for p in key {
                self.bounds = self
                    .bounds
                    .union(&Aabb::new(Vec3A::from(*p), Vec3A::from(*p)));
            }
        }
        self.deformation = Some(Arc::new(Deformation {
            positions,
            normals,
            texture_space,
        }));
        self
    }

    /// The mesh deforms over the shutter (see `Deformation`).
    pub fn deforms(&self) -> bool {
        self.deformation.is_some()
    }

    /// Per triangle, the box it sweeps over the shutter (a deforming mesh's BVH primitives).
    fn swept_boxes(&self, d: &Deformation) -> Vec<Aabb> {
        self.indices
            .par_iter()
            .map(|t| {
                let mut b = Aabb::empty();
                for key in &d.positions {
                    for &v in t {
                        let p = Vec3A::from(key[v as usize]);
                        b = b.union(&Aabb::new(p, p));
                    }
                }
                b
            })
            .collect()
    }

    /// The object-space box triangle `prim` sweeps over the shutter (None: a rigid mesh).
    pub fn swept_triangle_bounds(&self, prim: usize) -> Option<(Vec3, Vec3)> {
        let d = self.deformation.as_ref()?;
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for key in &d.positions {
            for &v in &self.indices[prim] {
                lo = lo.min(key[v as usize]);
                hi = hi.max(key[v as usize]);
            }
        }
        Some((lo, hi))
    }

    /// Object-space vertices of triangle `prim` at shutter time `time`.
    #[inline]
    pub fn vertices_at(&self, prim: usize, time: f32) -> [Vec3; 3] {
        match &self.deformation {
            None => self.vertices(prim),
            Some(d) => self.indices[prim].map(|v| d.position(v as usize, time)),
        }
    }

    /// Builds the mesh's own BVH if it has none, and puts the triangles in its leaf order so
    /// that traversal needs no indirection (triangle ids change: only before any hit exists).
    fn ensure_bvh(&mut self) {
        if self.bvh.is_some() {
            return;
        }
        let bvh = match &self.deformation {
            // Over the boxes the triangles sweep (not cached: deforming meshes change from
            // frame to frame).
            Some(d) => wide_bvh::build(&self.swept_boxes(d), build_params(self.tris.len())),
            None => cached_or_built_bvh(
                &self.tris,
                &[
                    bytemuck::cast_slice(&self.positions),
                    bytemuck::cast_slice(&self.indices),
                ],
            ),
        };
        let (tris, indices) = rayon::join(
            || leaf_order(&bvh, &self.tris),
            || leaf_order(&bvh, &self.indices),
        );
        self.tris = tris;
        self.indices = indices;
        self.bvh = Some(bvh);
    }

    /// Attaches per-vertex tangents (glTF `TANGENT`); ignored unless there is one per vertex
    /// and the mesh has shading normals (glTF 2.0 spec 3.7.2.1: without normals, tangents
    /// are ignored).
    /// Attaches the extra UV and colour sets (sets of the wrong length are dropped).
    pub fn with_attributes(
        mut self,
        extra_uvs: Vec<Option<Vec<Vec2>>>,
        colors: Vec<Option<Vec<Vec4>>>,
    ) -> Self {
        let n = self.positions.len();
        self.extra_uvs = extra_uvs
            .into_iter()
            .map(|u| u.filter(|u| u.len() == n))
            .collect();
        self.colors = colors
            .into_iter()
            .map(|c| c.filter(|c| c.len() == n))
            .collect();
        self
    }

    pub fn with_tangents(mut self, tangents: Option<Vec<Vec4>>) -> Self {
        self.tangents =
            tangents.filter(|t| t.len() == self.positions.len() && self.normals.is_some());
        self
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    pub fn vertices(&self, prim: usize) -> [Vec3; 3] {
        let t = &self.tris[prim];
        [t.v0, t.v0 + t.e1, t.v0 + t.e2]
    }

    pub fn aabb(&self) -> Aabb {
        self.bounds
    }

    fn bvh(&self) -> &CwBvh {
        self.bvh
            .as_ref()
            .expect("Geometry::new builds the BVH of every mesh it traces through the TLAS")
    }

    /// The triangle `id` as the Möller–Trumbore test takes it, at shutter time `time`.
    #[inline]
    fn triangle_at(&self, id: usize, time: f32) -> TriangleEdges {
        match &self.deformation {
            None => self.tris[id],
            Some(d) => {
                let [v0, v1, v2] = self.indices[id].map(|v| d.position(v as usize, time));
                TriangleEdges {
                    v0,
                    e1: v1 - v0,
                    e2: v2 - v0,
                }
            }
        }
    }

    /// Closest hit along an object-space ray at shutter time `time`: (t, primitive, b1, b2).
    #[inline]
    fn intersect(&self, ray: &BvhRay, time: f32, best: &mut BlasHit) -> f32 {
        let origin = Vec3::from(ray.origin);
        let dir = Vec3::from(ray.direction);
        let mut local = BlasHit {
            t: ray.tmax,
            ..*best
        };
        traversal::closest(self.bvh(), *ray, |r, id| {
            let tri = self.triangle_at(id, time);
            match intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax) {
                Some((t, b1, b2)) => {
                    local = BlasHit {
                        t,
                        prim: id as u32,
                        b1,
                        b2,
                        instance: best.instance,
                    };
                    t
                }
                None => f32::INFINITY,
            }
        });
        if local.t < ray.tmax {
            *best = local;
            local.t
        } else {
            f32::INFINITY
        }
    }

    /// Every hit along an object-space ray at shutter time `time`: (t, primitive, b1, b2).
    fn for_each_hit(&self, ray: &BvhRay, time: f32, mut f: impl FnMut(f32, u32, f32, f32)) {
        let origin = Vec3::from(ray.origin);
        let dir = Vec3::from(ray.direction);
        traversal::every(self.bvh(), *ray, |r, id| {
            let tri = self.triangle_at(id, time);
            if let Some((t, b1, b2)) =
                intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax)
            {
                f(t, id as u32, b1, b2);
            }
        });
    }

    #[inline]
    fn occluded(&self, ray: &BvhRay, time: f32) -> bool {
        let origin = Vec3::from(ray.origin);
        let dir = Vec3::from(ray.direction);
        !traversal::misses(self.bvh(), *ray, |r, id| {
            let tri = self.triangle_at(id, time);
            intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax)
                .map_or(f32::INFINITY, |h| h.0)
        })
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct BlasHit {
    t: f32,
    prim: u32,
    b1: f32,
    b2: f32,
    instance: u32,
}

/// Where an instance is at one time: its transform and what derives from it.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    pub object_to_world: Affine3A,
    pub world_to_object: Affine3A,
    /// Inverse transpose of the linear part: transforms normals.
    pub normal_to_world: Mat3,
    /// Odd-handed transform (negative determinant): winding and geometric normal flip.
    pub flips_handedness: bool,
}

impl Placement {
    pub fn new(object_to_world: Affine3A) -> Self {
        let m3 = Mat3::from(object_to_world.matrix3);
        Placement {
            object_to_world,
            world_to_object: object_to_world.inverse(),
            normal_to_world: m3.inverse().transpose(),
            flips_handedness: m3.determinant() < 0.0,
        }
    }
}

/// A mesh placed in the world.
pub struct Instance {
    pub mesh: u32,
    /// The placement at shutter time 0.5 (the only one without motion); what is not traced at
    /// a time (light selection's estimates, volume grids) uses it.
    pub placement: Placement,
    /// The placement over the shutter of a moving instance (transform motion blur).
    pub motion: Option<Arc<MotionTransform>>,
    /// False for meshes that stand for lights (Blender area lights are not geometry): shadow
    /// rays pass through them.
    pub casts_shadows: bool,
    /// False hides the instance from camera rays (the integrator looks through it).
    pub camera_visible: bool,
    /// A light, not geometry (a Blender area light's mesh): rays take its emission and pass
    /// on, so it is no path vertex, as it casts no shadow (`casts_shadows` is false too).
    pub light_only: bool,
    /// A hole in the image (Blender's holdout): camera rays that reach it leave the pixel
    /// transparent, and paths end there.
    pub holdout: bool,
    /// Which scattering sees the instance's emission (an area light's ray visibility).
    pub light_visibility: crate::bsdf::RayVisibility,
}

impl Instance {
    pub fn new(mesh: u32, object_to_world: Affine3A) -> Self {
        Instance {
            mesh,
            placement: Placement::new(object_to_world),
            motion: None,
            casts_shadows: true,
            camera_visible: true,
            light_only: false,
            holdout: false,
            light_visibility: crate::bsdf::RayVisibility::ALL,
        }
    }

    pub fn with_visibility(mut self, casts_shadows: bool, camera_visible: bool) -> Self {
        self.casts_shadows = casts_shadows;
        self.camera_visible = camera_visible;
        self
    }

    /// The world-space ray `ray` (up to `t_max`) in this instance's object space at the ray's
    /// shutter time, as the mesh's BVH takes it (t is the same parameter in both spaces).
    #[inline]
    fn object_ray(&self, ray: &Ray, t_max: f32) -> BvhRay {
        let to_object = self.placement_at(ray.time).world_to_object;
        bvh_ray(
            to_object.transform_point3(ray.origin),
            to_object.transform_vector3(ray.dir),
            t_max,
        )
    }

    pub fn with_light_only(mut self, light_only: bool) -> Self {
        self.light_only = light_only;
        self
    }

    pub fn with_holdout(mut self, holdout: bool) -> Self {
        self.holdout = holdout;
        self
    }

    pub fn with_light_visibility(mut self, v: crate::bsdf::RayVisibility) -> Self {
        self.light_visibility = v;
        self
    }

    /// Moves the instance over the shutter (`motion`'s keys replace the transform); a motion
    /// whose keys are all equal leaves it static.
    pub fn with_motion(mut self, motion: MotionTransform) -> Self {
        if !motion.is_static() {
            self.placement = Placement::new(motion.at(0.5));
            self.motion = Some(Arc::new(motion));
        }
        self
    }

    /// The placement at shutter time `time`.
    #[inline]
    pub fn placement_at(&self, time: f32) -> Cow<'_, Placement> {
        match &self.motion {
            None => Cow::Borrowed(&self.placement),
            Some(m) => Cow::Owned(Placement::new(m.at(time))),
        }
    }
}

/// Closest-hit record in world space.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub instance: u32,
    pub prim: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub b1: f32,
    pub b2: f32,
    /// The ray's shutter time.
    pub time: f32,
}

/// Everything the shading code needs about a surface point, in world space.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Geometric normal (unit, from the winding, as placed in the world).
    pub ng: Vec3,
    /// Interpolated shading normal (unit), on the same side as `ng`; normal mapping replaces
    /// it (`Geometry::apply_normal_map`).
    pub ns: Vec3,
    /// The interpolated normal before any normal map (equal to `ns` without one).
    pub ns_smooth: Vec3,
    /// dp/du direction for a stable tangent frame (may be zero).
    pub dpdu: Vec3,
    pub uv: Vec2,
    pub material: u32,
    pub instance: u32,
    pub prim: u32,
    /// Barycentric weights of vertices 1 and 2 (to interpolate more vertex data later).
    pub b1: f32,
    pub b2: f32,
    /// World-space area of the triangle (for light pdfs).
    pub area: f32,
    /// Shutter time at which the instance was placed here.
    pub time: f32,
}

/// All geometry of a scene: the instances whose mesh no other instance uses flattened into
/// one world-space BVH (`FlatLevel`), the others under a two-level BVH.
pub struct Geometry {
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
    flat: Option<FlatLevel>,
    /// Whether instance i is in the flattened level (else under the TLAS).
    flattened: Vec<bool>,
    /// Over the instances that are not flattened (empty when there are none).
    tlas: CwBvh,
    /// Those instances in TLAS leaf order (ids the traversal reports).
    tlas_order: Vec<u32>,
    bounds: Aabb,
    /// `bounds` grown by 1e-4 of its size (`misses_bounds`).
    cull_bounds: Aabb,
}

/// The triangles of every instance whose mesh no other instance uses, in world space under one
/// BVH, as Cycles builds one BVH for all objects that are not instanced. Under a two-level BVH
/// the boxes of a scene's objects overlap (a floor, walls and the objects on them), and a ray
/// descends into several meshes' BVHs, transforming itself for each; flattened, one traversal
/// culls triangles of all of them together. Hits report the instance and the mesh's own
/// triangle id, so shading reads the mesh as before.
struct FlatLevel {
    bvh: CwBvh,
    /// World-space triangles in BVH leaf order.
    tris: Vec<TriangleEdges>,
    /// (instance, triangle of its mesh) per entry of `tris`.
    owners: Vec<(u32, u32)>,
}

impl FlatLevel {
    /// None when no instance qualifies. `flat[i]` says whether instance i is flattened.
    fn build(meshes: &[Mesh], instances: &[Instance], flat: &[bool]) -> Option<FlatLevel> {
        let owners: Vec<(u32, u32)> = instances
            .iter()
            .enumerate()
            .filter(|(i, _)| flat[*i])
            .flat_map(|(i, inst)| {
                (0..meshes[inst.mesh as usize].tris.len() as u32).map(move |p| (i as u32, p))
            })
            .collect();
        if owners.is_empty() {
            return None;
        }
        let tris: Vec<TriangleEdges> = owners
            .par_iter()
            .map(|&(i, p)| {
                let inst = &instances[i as usize];
                let t = &meshes[inst.mesh as usize].tris[p as usize];
                let m = &inst.placement.object_to_world;
                let v0 = m.transform_point3(t.v0);
                TriangleEdges {
                    v0,
                    e1: m.transform_point3(t.v0 + t.e1) - v0,
                    e2: m.transform_point3(t.v0 + t.e2) - v0,
                }
            })
            .collect();
        // Cached like the meshes' BVHs (a re-render with nothing moved skips the build), keyed
        // by the world-space triangles themselves.
        let bvh = cached_or_built_bvh(&tris, &[bytemuck::cast_slice(&tris)]);
        let (tris, owners) = rayon::join(|| leaf_order(&bvh, &tris), || leaf_order(&bvh, &owners));
        Some(FlatLevel { bvh, tris, owners })
    }

    /// Closest hit below `best.t`, written into `best`.
    #[inline]
    fn intersect(&self, ray: &Ray, best: &mut BlasHit) {
        let (origin, dir) = (ray.origin, ray.dir);
        let mut found = None;
        traversal::closest(&self.bvh, bvh_ray(origin, dir, best.t), |r, id| {
            let tri = &self.tris[id];
            match intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax) {
                Some((t, b1, b2)) => {
                    found = Some((id, t, b1, b2));
                    t
                }
                None => f32::INFINITY,
            }
        });
        if let Some((id, t, b1, b2)) = found {
            let (instance, prim) = self.owners[id];
            *best = BlasHit {
                t,
                prim,
                b1,
                b2,
                instance,
            };
        }
    }

    /// Every hit on the segment (0, t_max): (t, instance, primitive, b1, b2).
    fn for_each_hit(&self, ray: &Ray, t_max: f32, mut f: impl FnMut(f32, u32, u32, f32, f32)) {
        let (origin, dir) = (ray.origin, ray.dir);
        traversal::every(&self.bvh, bvh_ray(origin, dir, t_max), |r, id| {
            let tri = &self.tris[id];
            if let Some((t, b1, b2)) =
                intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax)
            {
                let (instance, prim) = self.owners[id];
                f(t, instance, prim, b1, b2);
            }
        });
    }

    /// Whether a triangle of a shadow-casting instance lies on the segment (0, t_max).
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32, instances: &[Instance]) -> bool {
        let (origin, dir) = (ray.origin, ray.dir);
        !traversal::misses(&self.bvh, bvh_ray(origin, dir, t_max), |r, id| {
            if !instances[self.owners[id].0 as usize].casts_shadows {
                return f32::INFINITY;
            }
            let tri = &self.tris[id];
            intersect_triangle(origin, dir, tri.v0, tri.e1, tri.e2, r.tmax)
                .map_or(f32::INFINITY, |h| h.0)
        })
    }
}

/// How `Geometry` arranges its BVHs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhLayout {
    /// Instances whose mesh no other instance uses in one world-space BVH, shared meshes under
    /// a two-level BVH: the fastest to trace (final renders).
    Flattened,
    /// Every instance under the top level: moving an object rebuilds only the top level (the
    /// interactive viewport, where objects move between frames).
    TwoLevel,
}

impl Geometry {
    pub fn new(meshes: Vec<Mesh>, instances: Vec<Instance>) -> Self {
        Self::with_layout(meshes, instances, BvhLayout::Flattened)
    }

    pub fn with_layout(mut meshes: Vec<Mesh>, instances: Vec<Instance>, layout: BvhLayout) -> Self {
        let mut uses = vec![0u32; meshes.len()];
        for inst in &instances {
            uses[inst.mesh as usize] += 1;
        }
        let flattened: Vec<bool> = instances
            .iter()
            .map(|inst| {
                layout == BvhLayout::Flattened
                    && uses[inst.mesh as usize] == 1
                    && inst.motion.is_none()
                    && !meshes[inst.mesh as usize].deforms()
            })
            .collect();
        let mut needs_bvh = vec![false; meshes.len()];
        for (inst, &flat) in instances.iter().zip(&flattened) {
            needs_bvh[inst.mesh as usize] |= !flat;
        }
        meshes
            .par_iter_mut()
            .zip(&needs_bvh)
            .filter(|(_, &needed)| needed)
            .for_each(|(mesh, _)| mesh.ensure_bvh());
        let flat = FlatLevel::build(&meshes, &instances, &flattened);
        let mut geometry = Geometry {
            meshes,
            instances,
            flat,
            flattened,
            tlas: CwBvh::default(),
            tlas_order: Vec::new(),
            bounds: Aabb::empty(),
            cull_bounds: Aabb::empty(),
        };
        geometry.build_top_level();
        geometry
    }

    /// Scene bounds and the top-level BVH over the instances that are not flattened, from the
    /// instances' current transforms.
    fn build_top_level(&mut self) {
        let aabbs: Vec<Aabb> = self
            .instances
            .iter()
            .map(|inst| {
                let b = self.meshes[inst.mesh as usize].aabb();
                match &inst.motion {
                    None => transform_aabb(&b, &inst.placement.object_to_world),
                    // Moving instances are under the top level with the box they sweep.
                    Some(m) => m.bounds(&b),
                }
            })
            .collect();
        self.bounds = aabbs.iter().fold(Aabb::empty(), |b, a| b.union(a));
        let margin = 1e-4 * (self.bounds.max - self.bounds.min).max_element() + 1e-6;
        self.cull_bounds = Aabb::new(self.bounds.min - margin, self.bounds.max + margin);
        let shared: Vec<u32> = (0..self.instances.len() as u32)
            .filter(|&i| !self.flattened[i as usize])
            .collect();
        (self.tlas, self.tlas_order) = if shared.is_empty() {
            (CwBvh::default(), Vec::new())
        } else {
            let shared_aabbs: Vec<Aabb> = shared.iter().map(|&i| aabbs[i as usize]).collect();
            let tlas = wide_bvh::build(&shared_aabbs, build_params(shared_aabbs.len()));
            let order = tlas
                .primitive_indices
                .iter()
                .map(|&k| shared[k as usize])
                .collect();
            (tlas, order)
        };
    }

    /// Moves instances (index, new object-to-world). Instances under the top level cost only a
    /// top-level rebuild; moving a flattened one rebuilds the flattened level as well.
    pub fn set_transforms(&mut self, moves: &[(u32, Affine3A)]) {
        let mut flat_moved = false;
        for &(i, m) in moves {
            let inst = &mut self.instances[i as usize];
            // The new transform replaces any motion: the viewport shows one time.
            inst.placement = Placement::new(m);
            inst.motion = None;
            flat_moved |= self.flattened[i as usize];
        }
        if flat_moved {
            self.flat = FlatLevel::build(&self.meshes, &self.instances, &self.flattened);
        }
        self.build_top_level();
    }

    /// World-space bounding box of everything (empty box if there is no geometry).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.bounds.min.into(), self.bounds.max.into())
    }

    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// True when `ray` certainly meets nothing: its line misses the box around all geometry
    /// (over the shutter), grown by a margin far above rounding. One slab test instead of a
    /// traversal for the camera rays that pass beside everything, which cost a traversal's
    /// set-up and the root's eight child boxes only to find nothing.
    pub fn misses_bounds(&self, ray: &Ray) -> bool {
        if self.is_empty() {
            return true;
        }
        let line = bvh_ray(ray.origin, ray.dir, f32::INFINITY);
        let grown = &self.cull_bounds;
        grown.min.is_finite()
            && grown.max.is_finite()
            && grown.intersect_ray(&line) == f32::INFINITY
    }

    /// The instance is a holdout (see `Instance::holdout`).
    pub fn is_holdout(&self, instance: u32) -> bool {
        self.instances[instance as usize].holdout
    }

    /// Some instance is a holdout.
    pub fn has_holdout(&self) -> bool {
        self.instances.iter().any(|i| i.holdout)
    }

    /// Camera rays see this instance (see `Instance::camera_visible`).
    #[inline]
    pub fn camera_visible(&self, instance: u32) -> bool {
        self.instances[instance as usize].camera_visible
    }

    /// Rays pass this instance after taking its emission (see `Instance::light_only`).
    #[inline]
    pub fn light_only(&self, instance: u32) -> bool {
        self.instances[instance as usize].light_only
    }

    /// Closest intersection with t in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        let mut best = BlasHit {
            t: t_max,
            ..Default::default()
        };
        if let Some(flat) = &self.flat {
            flat.intersect(ray, &mut best);
        }
        if !self.tlas_order.is_empty() {
            self.intersect_shared(ray, &mut best);
        }
        (best.t < t_max).then_some(Hit {
            t: best.t,
            instance: best.instance,
            prim: best.prim,
            b1: best.b1,
            b2: best.b2,
            time: ray.time,
        })
    }

    /// Closest hit below `best.t` among the instances that share their mesh (the TLAS).
    fn intersect_shared(&self, ray: &Ray, best: &mut BlasHit) {
        let world = bvh_ray(ray.origin, ray.dir, best.t);
        traversal::closest(&self.tlas, world, |r, id| {
            let inst_id = self.tlas_order[id];
            let inst = &self.instances[inst_id as usize];
            let local = inst.object_ray(ray, r.tmax);
            let before = *best;
            best.instance = inst_id;
            let t = self.meshes[inst.mesh as usize].intersect(&local, ray.time, best);
            if t == f32::INFINITY {
                *best = before;
            }
            t
        });
    }

    /// Calls `f` with every intersection with t in (0, t_max), in no particular order, in one
    /// traversal of the BVHs (a closest-hit query per hit would traverse them once per hit).
    pub fn for_each_hit(&self, ray: &Ray, t_max: f32, mut f: impl FnMut(Hit)) {
        if self.is_empty() {
            return;
        }
        let time = ray.time;
        let mut found = |t, instance, prim, b1, b2| {
            f(Hit {
                t,
                instance,
                prim,
                b1,
                b2,
                time,
            })
        };
        if let Some(flat) = &self.flat {
            flat.for_each_hit(ray, t_max, &mut found);
        }
        if self.tlas_order.is_empty() {
            return;
        }
        traversal::every(&self.tlas, bvh_ray(ray.origin, ray.dir, t_max), |_, id| {
            let inst_id = self.tlas_order[id];
            let inst = &self.instances[inst_id as usize];
            let local = inst.object_ray(ray, t_max);
            self.meshes[inst.mesh as usize].for_each_hit(&local, time, |t, prim, b1, b2| {
                found(t, inst_id, prim, b1, b2)
            });
        });
    }

    /// True if anything blocks the segment origin + t dir, t in (0, t_max).
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if self.is_empty() {
            return false;
        }
        if let Some(flat) = &self.flat {
            if flat.occluded(ray, t_max, &self.instances) {
                return true;
            }
        }
        if self.tlas_order.is_empty() {
            return false;
        }
        let world = bvh_ray(ray.origin, ray.dir, t_max);
        !traversal::misses(&self.tlas, world, |_, id| {
            let inst = &self.instances[self.tlas_order[id] as usize];
            if !inst.casts_shadows {
                return f32::INFINITY;
            }
            let local = inst.object_ray(ray, t_max);
            if self.meshes[inst.mesh as usize].occluded(&local, ray.time) {
                // any distance below t_max counts as a hit; 0.5 * t_max is not < t_max when
                // t_max is infinite (directional and world lights)
                0.0
            } else {
                f32::INFINITY
            }
        })
    }

    /// World-space surface data at a hit.
    pub fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        self.surface_point_at(hit.instance, hit.prim, hit.b1, hit.b2, hit.time)
    }

    /// What a shading graph reads at `sp` (see `crate::shading::ShadingInputs`); `wo` points
    /// towards the viewer, `camera_ray` says whether the camera sees `sp` directly.
    pub fn shading_inputs(
        &self,
        sp: &SurfacePoint,
        wo: Vec3,
        camera_ray: bool,
    ) -> crate::shading::ShadingInputs {
        self.surface_inputs(sp, wo, camera_ray, true)
    }

    /// As [`Geometry::shading_inputs`]; without `object_space` the object-space and
    /// tangent-frame inputs keep their defaults (for graphs that do not read them,
    /// `ShadingGraph::reads_object_space`).
    pub fn surface_inputs(
        &self,
        sp: &SurfacePoint,
        wo: Vec3,
        camera_ray: bool,
        object_space: bool,
    ) -> crate::shading::ShadingInputs {
        use crate::shading::graph::blender_uv;
        let inst = &self.instances[sp.instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let [i0, i1, i2] = mesh.indices[sp.prim as usize].map(|i| i as usize);
        let (b1, b2) = (sp.b1, sp.b2);
        let b0 = 1.0 - b1 - b2;
        let mut out = crate::shading::ShadingInputs {
            position: sp.p,
            incoming: wo,
            camera_ray,
            ..Default::default()
        };
        out.uv[0] = blender_uv(sp.uv);
        for (k, set) in mesh.extra_uvs.iter().enumerate().take(out.uv.len() - 1) {
            if let Some(u) = set {
                out.uv[k + 1] = blender_uv(u[i0] * b0 + u[i1] * b1 + u[i2] * b2);
            }
        }
        for (k, set) in mesh.colors.iter().enumerate().take(out.color.len()) {
            if let Some(c) = set {
                out.color[k] = c[i0] * b0 + c[i1] * b1 + c[i2] * b2;
            }
        }
        // Cycles flips the normals of a backfacing hit towards the viewer for every node.
        let backfacing = sp.ng.dot(wo) < 0.0;
        let flip = if backfacing { -1.0 } else { 1.0 };
        out.backfacing = backfacing;
        out.normal = sp.ns * flip;
        out.true_normal = sp.ng * flip;
        if !object_space {
            return out;
        }
        (out.tangent, out.bitangent) = self.normal_map_frame(sp);
        let placement = inst.placement_at(sp.time);
        out.object = placement.world_to_object.transform_point3(sp.p);
        out.normal_to_world = Mat3::from(placement.world_to_object.matrix3).transpose();
        out.object_normal = placement
            .object_to_world
            .matrix3
            .transpose()
            .mul_vec3a(out.normal.into())
            .normalize_or_zero()
            .into();
        out.generated = generated_coordinates(mesh, out.object);
        out
    }

    /// What a shading graph reads at the world point `p` inside a volume of `instance`
    /// (Position, Object and Generated coordinates as on its surface; no normal or UVs).
    pub fn volume_inputs(&self, instance: u32, p: Vec3) -> crate::shading::ShadingInputs {
        let inst = &self.instances[instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let object = inst.placement.world_to_object.transform_point3(p);
        crate::shading::ShadingInputs {
            position: p,
            object,
            generated: generated_coordinates(mesh, object),
            ..Default::default()
        }
    }

    /// World-space bounding box corners of `instance`'s mesh (its object-space box transformed).
    pub fn instance_box_corners(&self, instance: u32) -> [Vec3; 8] {
        let inst = &self.instances[instance as usize];
        let b = self.meshes[inst.mesh as usize].aabb();
        let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
        std::array::from_fn(|i| {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            inst.placement.object_to_world.transform_point3(c)
        })
    }

    /// The shading inputs a Bump node needs at two points `step` (world units) from `sp` along
    /// `directions` (unit, in the triangle's plane; `ShadingGraph::bump_directions`), on the
    /// triangle's plane (attributes extrapolate linearly past the triangle, as with ray
    /// differentials). `centre` are the inputs at `sp` itself.
    pub fn bump_inputs(
        &self,
        sp: &SurfacePoint,
        centre: &crate::shading::ShadingInputs,
        step: f32,
        directions: [Vec3; 2],
    ) -> crate::shading::BumpInputs {
        let (wo, camera_ray) = (centre.incoming, centre.camera_ray);
        let inst = &self.instances[sp.instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let placement = inst.placement_at(sp.time);
        let (_, e1, e2) = world_edges(mesh, &placement, sp.prim, sp.time);
        let (e1, e2) = (Vec3::from(e1), Vec3::from(e2));
        // Barycentric steps (db1, db2) with db1 E1 + db2 E2 = the offset (its projection on
        // the plane): the normal equations of the two edges.
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = g11 * g22 - g12 * g12;
        let offset = |d: Vec3| -> SurfacePoint {
            let d = d * step;
            let (r1, r2) = (e1.dot(d), e2.dot(d));
            let (db1, db2) = if det.abs() > 1e-30 {
                ((g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det)
            } else {
                (0.0, 0.0)
            };
            self.surface_point_at(sp.instance, sp.prim, sp.b1 + db1, sp.b2 + db2, sp.time)
        };
        let (sx, sy) = (offset(directions[0]), offset(directions[1]));
        let mut dx = self.shading_inputs(&sx, wo, camera_ray);
        let mut dy = self.shading_inputs(&sy, wo, camera_ray);
        // The offset points belong to the same surface side as `sp`.
        for d in [&mut dx, &mut dy] {
            d.backfacing = centre.backfacing;
            d.normal = centre.normal;
            d.true_normal = centre.true_normal;
        }
        crate::shading::BumpInputs {
            dx,
            dy,
            dpdx: sx.p - sp.p,
            dpdy: sy.p - sp.p,
        }
    }

    /// World-space vertices of triangle `prim` of `instance` at shutter time `time`.
    #[inline]
    pub fn world_triangle(&self, instance: u32, prim: u32, time: f32) -> [Vec3; 3] {
        // The vertices `surface_point_at` reaches at barycentrics (0, 0), (1, 0) and (0, 1).
        let (w0, e1, e2) = self.world_edges_at(instance, prim, time);
        [w0, w0 + e1, w0 + e2].map(Vec3::from)
    }

    /// The world-space corner and edges of a triangle of an instance placed at shutter time
    /// `time`: `surface_point_at` reaches w0 + b1 e1 + b2 e2 (same arithmetic).
    pub fn world_edges_at(&self, instance: u32, prim: u32, time: f32) -> (Vec3A, Vec3A, Vec3A) {
        let inst = &self.instances[instance as usize];
        let placement = inst.placement_at(time);
        world_edges(&self.meshes[inst.mesh as usize], &placement, prim, time)
    }

    /// World-space surface data at barycentrics (b1, b2) of a triangle of an instance placed
    /// at shutter time `time`.
    pub fn surface_point_at(
        &self,
        instance: u32,
        prim: u32,
        b1: f32,
        b2: f32,
        time: f32,
    ) -> SurfacePoint {
        let inst = &self.instances[instance as usize];
        let placement = inst.placement_at(time);
        let mesh = &self.meshes[inst.mesh as usize];
        let [i0, i1, i2] = mesh.indices[prim as usize];
        let b0 = 1.0 - b1 - b2;
        let TrianglePoint {
            p,
            ng,
            e1,
            e2,
            area,
        } = triangle_point(mesh, &placement, prim, b1, b2, time);
        let ns = match &mesh.normals {
            Some(n) => {
                let corners = [i0, i1, i2].map(|v| v as usize);
                // A deforming mesh's normals at `time` if it has keyed normals (one test, not
                // one per corner).
                let [n0, n1, n2] = match mesh.deformation.as_deref() {
                    Some(d) if d.normals.is_some() => {
                        corners.map(|v| d.normal(v, time).unwrap_or(n[v]))
                    }
                    _ => corners.map(|v| n[v]),
                };
                let n_obj = n0 * b0 + n1 * b1 + n2 * b2;
                let n = (placement.normal_to_world * n_obj).normalize_or(ng);
                if n.is_finite() {
                    n
                } else {
                    ng
                }
            }
            None => ng,
        };
        // Keep the shading normal on the geometric normal's side: glTF normals define the
        // front, but a winding that disagrees with them must not make shading inconsistent.
        let ng = if ns.dot(ng) < 0.0 { -ng } else { ng };
        let (uv, dpdu) = match &mesh.uvs {
            Some(uvs) => {
                let (t0, t1, t2) = (uvs[i0 as usize], uvs[i1 as usize], uvs[i2 as usize]);
                let uv = t0 * b0 + t1 * b1 + t2 * b2;
                let (d1, d2) = (t1 - t0, t2 - t0);
                let det = d1.x * d2.y - d1.y * d2.x;
                let dpdu = if det.abs() > 1e-12 {
                    (e1 * d2.y - e2 * d1.y) / det
                } else {
                    Vec3::ZERO
                };
                (uv, dpdu)
            }
            // No TEXCOORD_0: every point reads texture coordinate (0, 0), as Cycles does for a
            // missing UV map (and as glTF viewers do), so a Blender scene exported without UVs
            // renders alike; the glTF loader warns when a textured material meets such a mesh.
            None => (Vec2::ZERO, e1),
        };
        SurfacePoint {
            p,
            ng,
            ns,
            ns_smooth: ns,
            dpdu,
            uv,
            material: mesh.material,
            instance,
            prim,
            b1,
            b2,
            area,
            time,
        }
    }

    /// Where `hit` is, its geometric normal (the triangle's winding, not yet turned to the
    /// shading normal's side as `surface_point` turns it) and material: the part of
    /// `surface_point` that a query choosing among many hits needs for each (the subsurface
    /// probe), bit for bit the same `p` and normal up to sign.
    pub fn hit_point(&self, hit: &Hit) -> (Vec3, Vec3, u32) {
        let inst = &self.instances[hit.instance as usize];
        let mesh = &self.meshes[inst.mesh as usize];
        let at = triangle_point(
            mesh,
            &inst.placement_at(hit.time),
            hit.prim,
            hit.b1,
            hit.b2,
            hit.time,
        );
        (at.p, at.ng, mesh.material)
    }

    /// The tangent frame of a tangent-space normal map at `sp` (glTF 2.0 spec 3.7.2.1 and
    /// 5.23): unit tangent T (+X of the map) and bitangent B (+Y of the map, "up" in the
    /// image), both orthogonal to `sp.ns`, with B = +-cross(ns, T) carrying the handedness.
    ///
    /// * With a `TANGENT` attribute: the interpolated object-space tangent goes to the world
    ///   by the instance's linear part (tangents are surface vectors, normals use the inverse
    ///   transpose), and the bitangent sign w is multiplied by sign(det M): for
    ///   B_obj = w cross(N, T), (M T) x (M B) = det(M) M^-T (T x B), so a mirroring transform
    ///   turns the triple around and cross(N', T') then points against M B.
    /// * Without one (or where it is unusable), T = dp/du and the "up" direction -dp/dv of
    ///   the triangle (glTF's v grows downwards in the image), from the world-space edges and
    ///   the UV deltas (pbrt-v4 "Triangle::InteractionFromIntersection" derivation). The sign
    ///   is that of (cross(ns, T) . -dp/dv), so mirrored UVs get a left-handed frame, as
    ///   MikkTSpace would give them. These per-triangle tangents equal MikkTSpace's wherever
    ///   the UV mapping is affine across neighbouring triangles (planes, boxes, cylinders'
    ///   sides); on curved meshes with distorted UVs MikkTSpace averages them per vertex and
    ///   the two differ slightly (the Blender add-on exports MikkTSpace tangents for this).
    ///   The spec's MikkTSpace would need vertex welding and per-vertex averaging at load;
    ///   the per-triangle derivation costs nothing in memory and is exact in the common case.
    /// * Degenerate UVs (zero-area UV triangle): an arbitrary frame around ns.
    ///
    /// T is Gram-Schmidt orthonormalised against the interpolated ns.
    pub fn normal_map_frame(&self, sp: &SurfacePoint) -> (Vec3, Vec3) {
        let inst = &self.instances[sp.instance as usize];
        let placement = inst.placement_at(sp.time);
        let mesh = &self.meshes[inst.mesh as usize];
        let [i0, i1, i2] = mesh.indices[sp.prim as usize];
        let (b1, b2) = (sp.b1, sp.b2);
        let b0 = 1.0 - b1 - b2;
        let ns = sp.ns;
        let orthonormal = |t: Vec3, sign: f32| -> Option<(Vec3, Vec3)> {
            let t = (t - ns * ns.dot(t)).try_normalize()?;
            Some((t, ns.cross(t) * sign))
        };
        if let Some(tan) = &mesh.tangents {
            let (t0, t1, t2) = (tan[i0 as usize], tan[i1 as usize], tan[i2 as usize]);
            // A zero tangent marks an unusable input value (see the glTF loader).
            if t0 != Vec4::ZERO && t1 != Vec4::ZERO && t2 != Vec4::ZERO {
                let t = t0 * b0 + t1 * b1 + t2 * b2;
                let mut sign = if t.w < 0.0 { -1.0 } else { 1.0 };
                if placement.flips_handedness {
                    sign = -sign;
                }
                let t_world = Mat3::from(placement.object_to_world.matrix3) * t.truncate();
                if let Some(frame) = orthonormal(t_world, sign) {
                    return frame;
                }
            }
        }
        let (_, e1, e2) = world_edges(mesh, &placement, sp.prim, sp.time);
        let (e1, e2) = (Vec3::from(e1), Vec3::from(e2));
        let (d1, d2) = match &mesh.uvs {
            Some(uvs) => {
                let t0 = uvs[i0 as usize];
                (uvs[i1 as usize] - t0, uvs[i2 as usize] - t0)
            }
            // No UVs (textures then read uv (0, 0) everywhere): a frame along the triangle's
            // parametric directions, as if its UVs were (0,0), (1,0), (0,1).
            None => (Vec2::X, Vec2::Y),
        };
        let det = d1.x * d2.y - d1.y * d2.x;
        if det.is_finite() && det.abs() > 1e-20 {
            let dpdu = (e1 * d2.y - e2 * d1.y) / det;
            let dpdv = (e2 * d1.x - e1 * d2.x) / det;
            let up = -dpdv;
            let sign = if ns.cross(dpdu).dot(up) < 0.0 {
                -1.0
            } else {
                1.0
            };
            if let Some(frame) = orthonormal(dpdu, sign) {
                return frame;
            }
        }
        let f = crate::math::Frame::from_normal(ns);
        (f.s, f.t)
    }

    /// Replaces `sp.ns` by the normal-mapped shading normal for a tangent-space normal `nt`
    /// (unit, +z = unperturbed). `wo` (unit, towards the viewer) keeps the result usable:
    /// a mapped normal can face away from the viewer or send the mirror direction below the
    /// geometric surface, where BSDFs return nothing and light is lost (black fringes) or,
    /// without the integrator's geometric-side checks, would leak. When the mirror
    /// direction R of `wo` about the mapped normal lies less than q above the geometric
    /// surface, the normal is replaced by the half vector between `wo` and the direction
    /// that keeps R's azimuth at elevation q, with q = min(0.9 cos(wo, ng), 0.01) (the rule
    /// Cycles applies to its microfacet closures, "ensure valid specular reflection"; the 0.9
    /// keeps q below cos(wo, ng), where the unperturbed normal always qualifies). Without `wo`
    /// (BSSRDF exit points, and materials with a diffuse base, which Cycles shades with the
    /// mapped normal as it is: see `Material::apply_normal_map`) the normal is only kept on
    /// the geometric normal's side.
    pub fn apply_normal_map(&self, sp: &mut SurfacePoint, nt: Vec3, wo: Option<Vec3>) {
        let (t, b) = self.normal_map_frame(sp);
        self.apply_world_normal(sp, t * nt.x + b * nt.y + sp.ns * nt.z, wo);
    }

    /// Replaces `sp.ns` by the world-space normal `n` (a bump or normal map's), kept a valid
    /// shading normal as [`Geometry::apply_normal_map`] does.
    pub fn apply_world_normal(&self, sp: &mut SurfacePoint, n: Vec3, wo: Option<Vec3>) {
        let Some(n) = n.try_normalize() else {
            return;
        };
        sp.ns = match wo.and_then(Vec3::try_normalize) {
            Some(wo) => {
                // Work on the viewer's side of the surface, then return to the outward one.
                let side = if wo.dot(sp.ng) < 0.0 { -1.0 } else { 1.0 };
                side * valid_reflection_normal(side * n, side * sp.ng, wo)
            }
            None => {
                let c = n.dot(sp.ng);
                if c >= 1e-3 {
                    n
                } else {
                    (n - sp.ng * (c - 1e-3)).try_normalize().unwrap_or(sp.ng)
                }
            }
        };
    }
}

/// Shadowing of a diffuse lobe shaded with a bumped/normal-mapped normal `ns` where the
/// surface's own (interpolated) normal is `n_smooth`, for light arriving from `wi` (all unit,
/// `ns` and `n_smooth` on the same side): Conty Estevez, Lecocq & Stein 2019, "A
/// Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem" (Ray Tracing Gems,
/// ch. 12). The mapped normals are treated as microfacets of a GGX surface whose roughness
/// follows from how far `ns` tilts, alpha^2 = tan^2(theta_d) / 8, and the light is masked by
/// Smith's G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2(theta_i))) with theta_i measured from
/// `n_smooth`: 1 for an untilted normal or light from above, falling smoothly to 0 at the
/// smooth horizon instead of the hard terminator a tilted normal otherwise gives. Cycles (4.x+)
/// applies this term to its diffuse closures whenever the closure normal differs from the
/// smooth one; measured on a plane, it darkens 31-degree tilts by 0.6% under a sun 37 degrees
/// from the zenith and by 7% at 69 degrees, as this function predicts.
pub fn bump_terminator_shadowing(n_smooth: Vec3, ns: Vec3, wi: Vec3) -> f32 {
    let cos_i = n_smooth.dot(wi);
    if !(cos_i > 0.0) {
        return 0.0;
    }
    let cos_d = n_smooth.dot(ns).min(1.0);
    if !(cos_d > 0.0) {
        return 0.0;
    }
    let tan2_d = (1.0 - cos_d * cos_d) / (cos_d * cos_d);
    let alpha2 = (0.125 * tan2_d).clamp(0.0, 1.0);
    let cos2_i = (cos_i * cos_i).max(1e-12);
    let tan2_i = (1.0 - cos2_i) / cos2_i;
    2.0 / (1.0 + (1.0 + alpha2 * tan2_i).sqrt())
}

/// See [`Geometry::apply_normal_map`]: `n`, `ng` and `wo` unit, `ng` on the side of `wo`.
fn valid_reflection_normal(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let cos_o = wo.dot(ng);
    if !(cos_o > 0.0) {
        return n;
    }
    let q = (0.9 * cos_o).min(0.01);
    let r = n * (2.0 * wo.dot(n)) - wo;
    if r.dot(ng) >= q && wo.dot(n) > 0.0 {
        return n;
    }
    // Keep R's azimuth around ng; fall back to the viewer's opposite azimuth.
    let tangential = (r - ng * r.dot(ng))
        .try_normalize()
        .or_else(|| (-wo + ng * cos_o).try_normalize());
    let Some(x) = tangential else {
        return ng;
    };
    let r_new = ng * q + x * (1.0 - q * q).max(0.0).sqrt();
    (wo + r_new).try_normalize().unwrap_or(ng)
}

pub(crate) fn transform_aabb(b: &Aabb, m: &Affine3A) -> Aabb {
    let mut out = Aabb::empty();
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        );
        out.extend(m.transform_point3(c).into());
    }
    out
}

/// Offsets a ray origin off a surface along the geometric normal, towards `dir`, so the
/// new ray does not re-hit the surface it leaves. The offset scales with the coordinates'
/// magnitude because float rounding of the hit point does.
#[inline]
pub fn offset_ray_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element()) * 0.1;
    if ng.dot(dir) >= 0.0 {
        p + ng * eps
    } else {
        p - ng * eps
    }
}

/// A point of a triangle in world space (`triangle_point`).
struct TrianglePoint {
    p: Vec3,
    /// Unit normal of the winding (e1 x e2).
    ng: Vec3,
    e1: Vec3,
    e2: Vec3,
    area: f32,
}

/// World-space vertex 0 and edges (v1 - v0, v2 - v0) of triangle `prim` of `mesh` placed by
/// `placement` at shutter time `time`. From the object-space vertex and edges the intersection
/// test uses (stored for a rigid mesh), the edges transformed as vectors: one point transform
/// instead of three, on every hit and light sample, and the edges carry no rounding of
/// v0 + e1 - v0.
#[inline]
fn world_edges(mesh: &Mesh, placement: &Placement, prim: u32, time: f32) -> (Vec3A, Vec3A, Vec3A) {
    let t = mesh.triangle_at(prim as usize, time);
    let m = &placement.object_to_world;
    (
        m.transform_point3a(t.v0.into()),
        m.transform_vector3a(t.e1.into()),
        m.transform_vector3a(t.e2.into()),
    )
}

/// The world-space point at barycentrics (b1, b2) of triangle `prim` of `mesh` placed by
/// `placement` at shutter time `time`, with the triangle's world edges, area and winding
/// normal.
#[inline]
fn triangle_point(
    mesh: &Mesh,
    placement: &Placement,
    prim: u32,
    b1: f32,
    b2: f32,
    time: f32,
) -> TrianglePoint {
    // p = w0 + b1 e1 + b2 e2 is the same affine combination as the transformed barycentric
    // point, without a fourth transform.
    let (w0, e1, e2) = world_edges(mesh, placement, prim, time);
    let p = w0 + e1 * b1 + e2 * b2;
    // The world-space cross product already accounts for mirroring transforms. One length
    // serves both the normal and the area.
    let cross = e1.cross(e2);
    let len = cross.length();
    let inv = len.recip();
    let ng = if inv.is_finite() && inv > 0.0 {
        cross * inv
    } else {
        Vec3A::Z
    };
    TrianglePoint {
        p: p.into(),
        ng: ng.into(),
        e1: e1.into(),
        e2: e2.into(),
        area: 0.5 * len,
    }
}

/// Texture Coordinate > Generated of the object-space point `object`: Blender's auto texture
/// space, the mesh's bounding box, an axis without extent widened to +-1 around its centre (so
/// a flat mesh reads 0.5 there).
fn generated_coordinates(mesh: &Mesh, object: Vec3) -> Vec3 {
    let b = match &mesh.deformation {
        Some(d) => d.texture_space,
        None => mesh.aabb(),
    };
    let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
    let centre = (lo + hi) * 0.5;
    let half = Vec3::select((hi - lo).cmpgt(Vec3::ZERO), (hi - lo) * 0.5, Vec3::ONE);
    (object - centre) / (2.0 * half) + Vec3::splat(0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The corrected normal always faces the viewer and keeps the mirror direction above the
    /// geometric surface; normals that already do are left alone.
    #[test]
    fn valid_reflection_normal_keeps_the_mirror_direction_up() {
        let ng = Vec3::Z;
        let mut seed = 12345u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..10_000 {
            let dir = |a: f32, b: f32, max_theta: f32| {
                let (phi, th) = (a * std::f32::consts::TAU, b * max_theta);
                Vec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos())
            };
            let wo = dir(rnd(), rnd(), std::f32::consts::FRAC_PI_2 - 1e-4);
            let n = dir(rnd(), rnd(), 1.55);
            let out = valid_reflection_normal(n, ng, wo);
            assert!(out.is_finite() && (out.length() - 1.0).abs() < 1e-4);
            assert!(wo.dot(out) > 0.0, "wo {wo} n {n} -> {out}");
            let r = out * (2.0 * wo.dot(out)) - wo;
            let q = (0.9 * wo.dot(ng)).min(0.01);
            assert!(r.dot(ng) >= q - 1e-4, "wo {wo} n {n} -> {out}, R.z {}", r.z);
            let r0 = n * (2.0 * wo.dot(n)) - wo;
            if r0.dot(ng) >= q && wo.dot(n) > 0.0 {
                assert_eq!(out, n);
            }
        }
    }
}
