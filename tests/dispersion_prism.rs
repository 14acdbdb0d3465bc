//! Analytic image test of dispersion: a narrow beam through a 55° prism onto a diffuse screen.
//!
//! Scene (glTF + material JSON written by the test, loaded like any user scene): the prism's
//! axis is the world y axis, so dispersion happens in the xz plane. A far emissive strip
//! (narrow across the beam, long along y) shines through a slit in a black baffle onto the
//! prism's entrance face, at the minimum-deviation angle of 500 nm. The beam leaves the exit
//! face onto a Lambertian screen perpendicular to the 500 nm ray; the baffle hides the light
//! from the screen except through the prism. A pinhole camera between prism and screen looks
//! straight at the screen (it never sees the prism), its image x axis along the dispersion.
//!
//! A unidirectional path tracer finds this caustic only by BSDF-sampling from the screen
//! through both smooth refractions into the area light, so the light subtends a small but
//! finite solid angle (about 2e-3 sr) and the image needs a few thousand samples per pixel:
//! each band collects only ~30-60 light-carrying samples at 2048 spp, which puts the seed-to-seed
//! spread of a measured centroid at ~0.15 px (0.3 px at 450 nm, where the exit angle is
//! steepest and the band widest; that wavelength gets twice the samples). Measured errors:
//! seeds 1-7 with 2048 spp for all wavelengths, |error| <= 0.66 px at 450 nm and <= 0.45 px
//! elsewhere; seeds 7 and 11-15 with these settings, |error| <= 0.59 px (mean -0.13 px at 600
//! and 650 nm, within noise of zero at the others).
//!
//! For each of five fixed wavelengths (`--lambda`: every path carries exactly lambda with
//! density 1, so the film receives f(lambda) * cmf(lambda)) the luminance-weighted centroid of
//! the band along image x is compared with the same centroid of the image predicted by an
//! independent forward computation: rays from a grid of points on the light through a grid of
//! points in the slit, Snell's law in 3D with eta(lambda) = A + B / lambda^2 at both faces
//! (unpolarised Fresnel transmittance), intersected with the screen plane and projected
//! through the glTF camera's pinhole model (pose and yfov as loaded, horizontal extent from
//! the image aspect, pixel (0, 0) at the top left). The 3D treatment matters: rays tilted out
//! of the dispersion plane by gamma see an effective index sqrt(n^2 - sin^2 gamma) / cos gamma
//! (the curved spectral lines of a prism spectrometer): the predicted centroids sit 0.4-1 px
//! from where the chief ray (light centre through slit centre) lands.
//!
//! Checks: |measured - predicted| < 1 px for every wavelength; bands ordered (red deviates
//! least) and more than 4 px apart (predicted gaps: 19.8, 11.4, 8.0, 6.1 px); and a control
//! computed (not rendered) with eta(550 nm) at every other wavelength lands more than 1 px (in
//! fact >= 8 px) from the measured band, so a non-dispersive or wrongly-dispersive prism
//! cannot pass.

#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use glam::{DVec3, Mat3, Quat, Vec3};
use gltf_builder::{test_dir, GltfBuilder, TRIANGLES};
use prism::integrator::WavelengthSampling;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, CameraDesc, Scene};
use serde_json::json;

// Glass: a fictitious, very dispersive Cauchy glass (lambda in micrometres; n = 1.89 at 450 nm,
// 1.58 at 650 nm) in a 55° prism at minimum deviation for 500 nm: the angular gaps between
// the bands (0.216, 0.125, 0.085, 0.063 rad) are large compared with the beam's divergence,
// which keeps the bands narrow, apart, and bright enough to find with few samples.
const CAUCHY_A: f64 = 1.3;
const CAUCHY_B: f64 = 0.12;
const APEX_DEG: f64 = 55.0;
const MIN_DEVIATION_NM: f64 = 500.0;
const WAVELENGTHS: [f64; 5] = [450.0, 500.0, 550.0, 600.0, 650.0];

// Image: 1 px = 0.0172 on the screen; each band is ~3 px wide at its base (~1.5 px FWHM),
// adjacent bands are >= 6 px apart.
const WIDTH: u32 = 64;
const HEIGHT: u32 = 24;
const SPP: u32 = 2048;
/// Half width (columns) of the window around the band's peak where the centroid is taken;
/// each image holds a single band and is black elsewhere, except for rare stray hits of other
/// paths through the prism (a few per image, 5-15 px away; one inside the window moves the
/// centroid by up to ~0.3 px).
const WINDOW: i64 = 6;

fn eta(lambda_nm: f64) -> f64 {
    let l = lambda_nm * 1e-3;
    CAUCHY_A + CAUCHY_B / (l * l)
}

/// Everything about the layout, in world units (f64 for the analytic side).
struct Layout {
    /// Prism: equilateral triangle (side `side`) in xz, extruded over y in [-half_len, half_len].
    tri: [DVec3; 3],
    half_len: f64,
    /// Beam direction from the light through the slit (unit, in the xz plane).
    d_in: DVec3,
    /// Unit vector across the beam in the xz plane (perpendicular to d_in).
    across: DVec3,
    slit_centre: DVec3,
    slit_width: f64,
    slit_height: f64,
    light_centre: DVec3,
    light_width: f64,
    light_height: f64,
    screen_centre: DVec3,
    /// Screen normal (facing the prism) and in-plane tangent (image +x).
    screen_normal: DVec3,
    screen_tangent: DVec3,
    screen_half: (f64, f64),
    camera_pos: DVec3,
    camera_forward: DVec3,
    yfov: f64,
}

fn layout() -> Layout {
    let side = 0.5;
    let half_apex = (APEX_DEG / 2.0).to_radians();
    // Base from B1 to B2 along x at z = 0, apex at +z. Entrance face B1-apex, exit apex-B2.
    let b1 = DVec3::new(-side * half_apex.sin(), 0.0, 0.0);
    let b2 = DVec3::new(side * half_apex.sin(), 0.0, 0.0);
    let apex = DVec3::new(0.0, 0.0, side * half_apex.cos());
    // Minimum deviation: the ray inside is parallel to the base, so the refraction angle is
    // A/2 and sin(theta_i) = n sin(A/2). The entrance face's inward normal is at -A/2 from +x
    // (angles in the xz plane measured towards +z), so d_in is at theta_i - A/2.
    let theta_i = (eta(MIN_DEVIATION_NM) * half_apex.sin()).asin();
    let phi = theta_i - half_apex;
    let d_in = DVec3::new(phi.cos(), 0.0, phi.sin());
    let across = DVec3::new(-phi.sin(), 0.0, phi.cos());
    let d_out = DVec3::new(phi.cos(), 0.0, -phi.sin()); // leaves symmetrically
    let m1 = (b1 + apex) * 0.5;
    let m2 = (apex + b2) * 0.5;
    let slit_centre = m1 - 0.3 * d_in;
    let screen_centre = m2 + 1.5 * d_out;
    // Image right = forward x up = d_out x y; blue (deviated most) lands at -0.35 along it,
    // red at +0.43: centre the view between.
    let screen_tangent = d_out.cross(DVec3::Y).normalize();
    let aim = screen_centre + 0.04 * screen_tangent;
    let camera_distance = 1.2;
    // Horizontal half-extent 32 px x 0.0172 = 0.55 at the screen.
    let tan_half_y = 0.55 / camera_distance * HEIGHT as f64 / WIDTH as f64;
    Layout {
        tri: [b1, apex, b2],
        half_len: 0.6,
        d_in,
        across,
        slit_centre,
        slit_width: 0.025,
        // Tall enough not to limit the tilt of the rays that reach the visible rows; the
        // light's height (+-0.8 at distance ~6 from the screen) sets it to about +-0.13 rad.
        slit_height: 1.0,
        light_centre: slit_centre - 4.0 * d_in,
        light_width: 0.048,
        light_height: 1.6,
        screen_centre,
        screen_normal: -d_out,
        screen_tangent,
        screen_half: (1.0, 0.75),
        camera_pos: aim - camera_distance * d_out,
        camera_forward: d_out,
        yfov: 2.0 * tan_half_y.atan(),
    }
}

fn v3(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// A mesh of triangles given in world space, each wound so its geometric normal points away
/// from `inside` (closed solids) or along `facing` (single quads).
fn add_mesh(b: &mut GltfBuilder, name: &str, tris: &[[DVec3; 3]], material: usize) {
    let mut pos = Vec::new();
    for t in tris {
        pos.extend(t.iter().map(|&p| v3(p)));
    }
    let idx: Vec<u16> = (0..pos.len() as u16).collect();
    let p = b.positions(&pos);
    let i = b.indices_u16(&idx);
    let m = b.mesh(
        name,
        vec![GltfBuilder::prim(p, Some(i), Some(material), TRIANGLES)],
    );
    b.root(json!({ "name": name, "mesh": m }));
}

fn orient(t: [DVec3; 3], outward: DVec3) -> [DVec3; 3] {
    if (t[1] - t[0]).cross(t[2] - t[0]).dot(outward) < 0.0 {
        [t[0], t[2], t[1]]
    } else {
        t
    }
}

/// Rectangle centre +- u_half * u +- v_half * v as two triangles facing `facing`.
fn rect(c: DVec3, u: DVec3, v: DVec3, u_half: f64, v_half: f64, facing: DVec3) -> Vec<[DVec3; 3]> {
    let p = |a: f64, b: f64| c + a * u_half * u + b * v_half * v;
    let (p00, p10, p11, p01) = (p(-1., -1.), p(1., -1.), p(1., 1.), p(-1., 1.));
    vec![
        orient([p00, p10, p11], facing),
        orient([p00, p11, p01], facing),
    ]
}

fn write_scene(l: &Layout) -> (std::path::PathBuf, std::path::PathBuf) {
    let mut b = GltfBuilder::new();
    b.use_ext("KHR_materials_specular");
    let black = b.material(json!({
        "name": "Black",
        "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
        "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } }
    }));
    let white = b.material(json!({
        "name": "Screen",
        "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
        "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } }
    }));
    let glass =
        b.material(json!({ "name": "Glass", "pbrMetallicRoughness": { "metallicFactor": 0.0 } }));
    let emitter = b.emissive_material("Emitter", 200.0);

    // Prism: closed, normals outward.
    let centroid = (l.tri[0] + l.tri[1] + l.tri[2]) / 3.0;
    let y = DVec3::Y * l.half_len;
    let mut prism = Vec::new();
    prism.push(orient(
        [l.tri[0] - y, l.tri[1] - y, l.tri[2] - y],
        -DVec3::Y,
    ));
    prism.push(orient([l.tri[0] + y, l.tri[1] + y, l.tri[2] + y], DVec3::Y));
    for k in 0..3 {
        let (a, c) = (l.tri[k], l.tri[(k + 1) % 3]);
        let out = ((a + c) * 0.5 - centroid).normalize();
        prism.push(orient([a - y, c - y, c + y], out));
        prism.push(orient([a - y, c + y, a + y], out));
    }
    add_mesh(&mut b, "Prism", &prism, glass);

    // Baffle: the plane through the slit, perpendicular to the beam, with the slit cut out.
    let (sw, sh, big) = (l.slit_width / 2.0, l.slit_height / 2.0, 3.0);
    let (s, a) = (l.slit_centre, l.across);
    let mut baffle = Vec::new();
    let w_side = (big - sw) / 2.0;
    baffle.extend(rect(
        s + (sw + w_side) * a,
        a,
        DVec3::Y,
        w_side,
        big,
        -l.d_in,
    ));
    baffle.extend(rect(
        s - (sw + w_side) * a,
        a,
        DVec3::Y,
        w_side,
        big,
        -l.d_in,
    ));
    let h_side = (big - sh) / 2.0;
    baffle.extend(rect(
        s + (sh + h_side) * DVec3::Y,
        a,
        DVec3::Y,
        sw,
        h_side,
        -l.d_in,
    ));
    baffle.extend(rect(
        s - (sh + h_side) * DVec3::Y,
        a,
        DVec3::Y,
        sw,
        h_side,
        -l.d_in,
    ));
    add_mesh(&mut b, "Baffle", &baffle, black);

    let light = rect(
        l.light_centre,
        a,
        DVec3::Y,
        l.light_width / 2.0,
        l.light_height / 2.0,
        l.d_in,
    );
    add_mesh(&mut b, "Light", &light, emitter);

    let screen = rect(
        l.screen_centre,
        l.screen_tangent,
        DVec3::Y,
        l.screen_half.0,
        l.screen_half.1,
        l.screen_normal,
    );
    add_mesh(&mut b, "Screen", &screen, white);

    // Camera: local -Z = forward, +Y = up, +X = forward x up.
    let f = l.camera_forward.as_vec3();
    let right = f.cross(Vec3::Y).normalize();
    let q = Quat::from_mat3(&Mat3::from_cols(right, Vec3::Y, -f)).normalize();
    let cam = b.camera(
        "PinholeData",
        l.yfov as f32,
        Some(WIDTH as f32 / HEIGHT as f32),
    );
    b.root(json!({
        "name": "Camera", "camera": cam,
        "translation": v3(l.camera_pos), "rotation": [q.x, q.y, q.z, q.w]
    }));

    let dir = test_dir("dispersion_prism");
    let gltf = b.write_gltf(&dir.join("prism.gltf"));
    let mat = dir.join("prism.materials.json");
    let sidecar = json!({
        "version": 1,
        "materials": {
            "Glass": { "dielectric": { "cauchy": { "a": CAUCHY_A, "b": CAUCHY_B }, "roughness": 0.0 } }
        }
    });
    std::fs::write(&mat, serde_json::to_string_pretty(&sidecar).unwrap()).unwrap();
    (gltf, mat)
}

/// The renderer's pinhole model (src/scene/camera.rs, glTF conventions): raster coordinates
/// in pixels of a world point, origin at the top-left corner.
struct Pinhole {
    world_to_camera: glam::DMat4,
    tan_half_x: f64,
    tan_half_y: f64,
}

impl Pinhole {
    fn new(c: &CameraDesc) -> Self {
        let tan_half_y = (0.5 * c.yfov as f64).tan();
        Pinhole {
            world_to_camera: c.camera_to_world.as_dmat4().inverse(),
            tan_half_x: tan_half_y * WIDTH as f64 / HEIGHT as f64,
            tan_half_y,
        }
    }

    fn raster(&self, p: DVec3) -> (f64, f64) {
        let q = self.world_to_camera.transform_point3(p);
        let ndc_x = q.x / -q.z / self.tan_half_x;
        let ndc_y = q.y / -q.z / self.tan_half_y;
        (
            (ndc_x + 1.0) * 0.5 * WIDTH as f64,
            (1.0 - ndc_y) * 0.5 * HEIGHT as f64,
        )
    }
}

/// Ray-plane intersection distance (plane through `p0` with normal `n`).
fn hit_plane(o: DVec3, d: DVec3, p0: DVec3, n: DVec3) -> Option<f64> {
    let denom = d.dot(n);
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = (p0 - o).dot(n) / denom;
    (t > 0.0).then_some(t)
}

/// Snell refraction of unit `d` at a surface with unit normal `n` facing against `d`,
/// from index n1 into n2; returns the direction and the unpolarised Fresnel transmittance.
fn refract(d: DVec3, n: DVec3, n1: f64, n2: f64) -> Option<(DVec3, f64)> {
    let cos_i = -d.dot(n);
    debug_assert!(cos_i > 0.0);
    let r = n1 / n2;
    let k = 1.0 - r * r * (1.0 - cos_i * cos_i);
    if k <= 0.0 {
        return None; // total internal reflection
    }
    let cos_t = k.sqrt();
    let t = r * d + (r * cos_i - cos_t) * n;
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    Some((t.normalize(), 1.0 - 0.5 * (rs * rs + rp * rp)))
}

/// Is `p` (on the plane of prism face k: tri[k] -> tri[k+1]) inside that face?
fn on_face(l: &Layout, k: usize, p: DVec3) -> bool {
    let (a, c) = (l.tri[k], l.tri[(k + 1) % 3]);
    let e = c - a;
    let s = (p - a).dot(e) / e.length_squared();
    (0.0..=1.0).contains(&s) && p.y.abs() <= l.half_len
}

/// Follows one ray from the light through the prism to the screen with index `n`; returns
/// the screen point and the product of the two Fresnel transmittances.
fn trace(l: &Layout, o: DVec3, d: DVec3, n: f64) -> Option<(DVec3, f64)> {
    let centroid = (l.tri[0] + l.tri[1] + l.tri[2]) / 3.0;
    let face_normal = |k: usize| {
        let (a, c) = (l.tri[k], l.tri[(k + 1) % 3]);
        let e = (c - a).normalize();
        let nrm = e.cross(DVec3::Y).normalize();
        if nrm.dot((a + c) * 0.5 - centroid) < 0.0 {
            -nrm
        } else {
            nrm
        }
    };
    // Entrance: face 0 (B1 -> apex); exit: face 1 (apex -> B2).
    let n0 = face_normal(0);
    let p1 = o + d * hit_plane(o, d, l.tri[0], n0)?;
    if !on_face(l, 0, p1) {
        return None;
    }
    let (d1, t1) = refract(d, n0, 1.0, n)?;
    let n1 = face_normal(1);
    let p2 = p1 + d1 * hit_plane(p1, d1, l.tri[1], n1)?;
    if !on_face(l, 1, p2) {
        return None; // would reach the base first
    }
    let (d2, t2) = refract(d1, -n1, n, 1.0)?;
    let p3 = p2 + d2 * hit_plane(p2, d2, l.screen_centre, l.screen_normal)?;
    let q = p3 - l.screen_centre;
    let on_screen =
        q.dot(l.screen_tangent).abs() <= l.screen_half.0 && q.y.abs() <= l.screen_half.1;
    on_screen.then_some((p3, t1 * t2))
}

/// Predicted luminance profile over image columns (summed over all rows) for index `n`:
/// irradiance on the Lambertian screen from a grid of light points x slit points, each pair
/// weighted by the geometry term cos_light cos_slit / r^2 and the Fresnel transmittances.
/// The camera looks perpendicular to the screen, so raster area per screen area is constant.
fn predicted_profile(l: &Layout, cam: &Pinhole, n: f64) -> Vec<f64> {
    let mut cols = vec![0.0; WIDTH as usize];
    let (nlx, nly, nsx, nsy) = (48, 12, 48, 12);
    let grid = |i: usize, n: usize| (i as f64 + 0.5) / n as f64 - 0.5;
    for i in 0..nlx {
        for j in 0..nly {
            let pl = l.light_centre
                + l.across * (l.light_width * grid(i, nlx))
                + DVec3::Y * (l.light_height * grid(j, nly));
            for k in 0..nsx {
                for m in 0..nsy {
                    let ps = l.slit_centre
                        + l.across * (l.slit_width * grid(k, nsx))
                        + DVec3::Y * (l.slit_height * grid(m, nsy));
                    let v = ps - pl;
                    let r2 = v.length_squared();
                    let d = v / r2.sqrt();
                    let g = d.dot(l.d_in) * d.dot(l.d_in) / r2;
                    if let Some((p, t)) = trace(l, ps, d, n) {
                        let (x, y) = cam.raster(p);
                        if (0.0..WIDTH as f64).contains(&x) && (0.0..HEIGHT as f64).contains(&y) {
                            cols[x as usize] += g * t;
                        }
                    }
                }
            }
        }
    }
    cols
}

/// Centroid (pixel centres at i + 0.5) of a column profile within +-WINDOW of its peak.
fn centroid(cols: &[f64]) -> f64 {
    let peak = (0..cols.len())
        .max_by(|&a, &b| cols[a].total_cmp(&cols[b]))
        .unwrap() as i64;
    let lo = (peak - WINDOW).max(0) as usize;
    let hi = ((peak + WINDOW) as usize).min(cols.len() - 1);
    let (mut s, mut sw) = (0.0, 0.0);
    for (x, &c) in cols.iter().enumerate().take(hi + 1).skip(lo) {
        s += (x as f64 + 0.5) * c;
        sw += c;
    }
    s / sw
}

#[test]
fn prism_bands_land_where_snell_says() {
    let l = layout();
    let (gltf, mat) = write_scene(&l);
    let desc = load_scene(&gltf, Some(&mat), None).expect("prism scene loads");
    let cam = Pinhole::new(desc.camera.as_ref().expect("camera"));
    let scene = Scene::build(desc).expect("prism scene builds");

    // The chief ray (light centre through slit centre) for reference in the report.
    let chief = |n: f64| {
        trace(&l, l.slit_centre, l.d_in, n)
            .map(|(p, _)| cam.raster(p).0)
            .unwrap()
    };

    let mut measured = Vec::new();
    for &lambda in &WAVELENGTHS {
        let settings = RenderSettings {
            width: WIDTH,
            height: HEIGHT,
            spp: if lambda == 450.0 { 2 * SPP } else { SPP },
            seed: 7,
            wavelengths: WavelengthSampling {
                fixed: Some(lambda as f32),
                ..Default::default()
            },
            ..Default::default()
        };
        let (film, stats) = render_quiet(&scene, &settings);
        assert_eq!(stats.discarded, 0);
        // Luminance Y straight from the film's XYZ (positive at a single wavelength).
        let mut cols = vec![0.0f64; WIDTH as usize];
        for (i, p) in film.pixels.iter().enumerate() {
            cols[i % WIDTH as usize] += p.xyz[1] / p.samples.max(1) as f64;
        }
        let total: f64 = cols.iter().sum();
        assert!(total > 0.0, "{lambda} nm: no light reached the screen");
        let got = centroid(&cols);
        let want = centroid(&predicted_profile(&l, &cam, eta(lambda)));
        let wrong = centroid(&predicted_profile(&l, &cam, eta(550.0)));
        eprintln!(
            "{lambda} nm: eta {:.4}  measured x = {got:.3}  predicted {want:.3}  (chief ray {:.3})  \
             error {:+.3} px  | control with eta(550) {wrong:.3} ({:+.2} px off)",
            eta(lambda),
            chief(eta(lambda)),
            got - want,
            got - wrong
        );
        assert!(
            (got - want).abs() < 1.0,
            "{lambda} nm: band centroid {got:.3} px, Snell's law says {want:.3} px"
        );
        if lambda != 550.0 {
            assert!(
                (got - wrong).abs() > 1.0,
                "{lambda} nm: the control with eta(550 nm) would pass too ({wrong:.3} px)"
            );
        }
        measured.push(got);
    }
    // Red deviates least: the bands move towards +x with wavelength, well apart.
    for k in 1..measured.len() {
        let gap = measured[k] - measured[k - 1];
        assert!(
            gap > 4.0,
            "bands {} and {} nm only {gap:.2} px apart",
            WAVELENGTHS[k - 1],
            WAVELENGTHS[k]
        );
    }
}
