//! Homogeneous volumes (`prism::media`): Beer-Lambert transmittance per wavelength, closed-form
//! emission, a camera inside a volume, shadow rays through volume boundaries, and white
//! furnaces for scattering volumes behind no surface and behind glass.

mod common;

use common::scenes::{camera, furnace_scene, glass_material, render_mean, slab_mesh};
use glam::{Mat4, Vec3};
use prism::geometry::Ray;
use prism::integrator::PathTracer;
use prism::integrator::WavelengthPdf;
use prism::lights::LightSelection;
use prism::media::CoefficientSpectrum;
use prism::sampler::Sampler;
use prism::scene::desc::{
    GltfMaterialDesc, InstanceDesc, IorDesc, MaterialDesc, PunctualKind, PunctualLightDesc,
    SceneDesc, VolumeDesc, WorldDesc,
};
use prism::scene::Scene;
use prism::spectrum::{RgbIlluminantSpectrum, SampledWavelengths};

/// A material with only a volume (Blender: nothing on Surface, a Volume shader on Volume).
fn volume_only(name: &str, volume: VolumeDesc) -> MaterialDesc {
    MaterialDesc {
        gltf: GltfMaterialDesc {
            name: name.into(),
            ..Default::default()
        },
        volume: Some(volume),
        null_surface: true,
        ..Default::default()
    }
}

fn instance(mesh: usize, object_to_world: Mat4) -> InstanceDesc {
    InstanceDesc {
        mesh,
        object_to_world,
        name: format!("object{mesh}"),
    }
}

fn world(radiance: f32) -> WorldDesc {
    WorldDesc {
        color: Vec3::splat(radiance),
        strength: 1.0,
        texture: None,
    }
}

/// A slab [-2, 2]^2 x [-depth, 0] of `material`, seen by a camera at z = 5 (outside).
fn slab_scene(material: MaterialDesc, depth: f32, world_radiance: f32) -> SceneDesc {
    SceneDesc {
        meshes: vec![slab_mesh(2.0, depth)],
        instances: vec![instance(0, Mat4::IDENTITY)],
        materials: vec![material],
        camera: Some(camera(5.0, 0.5)),
        world: world(world_radiance),
        ..Default::default()
    }
}

/// Radiance along `ray` at several wavelength sets (one sample each: the cases below are
/// deterministic), divided by the world's radiance at those wavelengths when it is not black
/// (white RGB upsampled as an illuminant is not 1 at every wavelength).
fn radiance_per_wavelength(
    scene: &Scene,
    ray: Ray,
    mut check: impl FnMut(&SampledWavelengths, [f32; 4]),
) {
    let tracer = PathTracer::new(scene, 64, LightSelection::Power);
    let world = RgbIlluminantSpectrum::new(Vec3::ONE);
    let world_lit = scene.materials.iter().all(|m| {
        m.interior()
            .is_none_or(|v| v.emitted_rgb().max_element() == 0.0)
    });
    for i in 0..16 {
        let w = SampledWavelengths::sample_hero((i as f32 + 0.5) / 16.0, WavelengthPdf::Visible);
        let mut sampler = Sampler::new(i, 0, 7);
        let mut r = tracer.radiance(ray, &w, &mut sampler).radiance;
        if world_lit {
            r = r.safe_div(world.sample(&w));
        }
        check(&w, r.0);
    }
}

#[test]
fn absorbing_slab_is_beer_lambert_per_wavelength() {
    let sigma_a = Vec3::new(0.9, 0.4, 0.1);
    let depth = 1.5;
    let fog = volume_only(
        "ink",
        VolumeDesc {
            sigma_a,
            ..Default::default()
        },
    );
    let scene = Scene::build(slab_scene(fog, depth, 1.0)).unwrap();
    let spectrum = CoefficientSpectrum::new(sigma_a);
    let ray = Ray::new(Vec3::new(0.3, -0.2, 5.0), Vec3::NEG_Z);
    radiance_per_wavelength(&scene, ray, |w, r| {
        let s = spectrum.sample(w);
        for k in 0..4 {
            let expected = (-s[k] * depth).exp();
            assert!(
                (r[k] - expected).abs() < 1e-4,
                "lambda {}: {} vs Beer-Lambert {expected}",
                w.lambda[k],
                r[k]
            );
        }
    });
    // A slanted ray crosses more of it: the path length is depth / cos.
    let dir = Vec3::new(0.6, 0.0, -0.8);
    radiance_per_wavelength(&scene, Ray::new(Vec3::new(-2.0, 0.0, 2.0), dir), |w, r| {
        let s = spectrum.sample(w);
        let expected = (-s[0] * depth / 0.8).exp();
        assert!((r[0] - expected).abs() < 1e-4, "{} vs {expected}", r[0]);
    });
}

#[test]
fn emitting_slab_matches_the_closed_form() {
    let (sigma_a, emission, depth) = (0.7f32, Vec3::new(2.0, 1.0, 0.5), 1.2f32);
    let glow = volume_only(
        "glow",
        VolumeDesc {
            sigma_a: Vec3::splat(sigma_a),
            emission,
            ..Default::default()
        },
    );
    let scene = Scene::build(slab_scene(glow, depth, 0.0)).unwrap();
    let e = RgbIlluminantSpectrum::new(emission);
    let grey = CoefficientSpectrum::new(Vec3::splat(sigma_a));
    radiance_per_wavelength(
        &scene,
        Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z),
        |w, r| {
            let (em, st) = (e.sample(w), grey.sample(w));
            for k in 0..4 {
                let expected = em[k] * (1.0 - (-st[k] * depth).exp()) / st[k];
                assert!(
                    (r[k] - expected).abs() < 1e-4 * expected.max(1.0),
                    "{} vs {expected}",
                    r[k]
                );
            }
        },
    );
}

#[test]
fn a_camera_inside_a_volume_starts_in_it() {
    // A box z in [-20, 0] around the camera at z = -5, looking down -z: 15 units of fog.
    let sigma_a = 0.05;
    let mut desc = slab_scene(
        volume_only(
            "haze",
            VolumeDesc {
                sigma_a: Vec3::splat(sigma_a),
                ..Default::default()
            },
        ),
        20.0,
        1.0,
    );
    desc.meshes = vec![slab_mesh(10.0, 20.0)];
    desc.camera = Some(camera(-5.0, 0.5));
    let scene = Scene::build(desc).unwrap();
    let grey = CoefficientSpectrum::new(Vec3::splat(sigma_a));
    radiance_per_wavelength(
        &scene,
        Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::NEG_Z),
        |w, r| {
            let expected = (-grey.sample(w)[0] * 15.0).exp();
            assert!((r[0] - expected).abs() < 1e-4, "{} vs {expected}", r[0]);
        },
    );
}

/// A diffuse floor (albedo 0.5) at z = 0 under a sun straight above, with `volume` drawn as
/// `mesh` (a slab whose top is at its z = 0) lifted by `lift`, between them; black world.
fn sunlit_floor_under(
    volume: MaterialDesc,
    mut mesh: prism::scene::desc::MeshDesc,
    lift: f32,
) -> SceneDesc {
    let floor = common::scenes::quad_mesh("floor", Vec3::ZERO, Vec3::X * 5.0, Vec3::Y * 5.0, 0);
    mesh.material = Some(1);
    SceneDesc {
        meshes: vec![floor, mesh],
        instances: vec![
            instance(0, Mat4::IDENTITY),
            instance(1, Mat4::from_translation(Vec3::new(0.0, 0.0, lift))),
        ],
        materials: vec![
            common::scenes::diffuse_material("floor", Vec3::splat(0.5)),
            volume,
        ],
        lights: vec![PunctualLightDesc {
            kind: PunctualKind::Directional,
            direction: Vec3::NEG_Z,
            intensity: 3.0,
            color: Vec3::ONE,
            ..Default::default()
        }],
        camera: Some(camera(10.0, 0.5)),
        world: world(0.0),
        ..Default::default()
    }
}

#[test]
fn shadow_rays_are_attenuated_by_the_volumes_they_cross() {
    // A diffuse floor at z = 0 under a sun from straight above; an absorbing box
    // [-1, 1]^2 x [1, 1.5] (no surface) between them shades x < 1 by exp(-sigma_a 0.5).
    let sigma_a = 0.8;
    let smoke = volume_only(
        "smoke",
        VolumeDesc {
            sigma_a: Vec3::splat(sigma_a),
            ..Default::default()
        },
    );
    let desc = sunlit_floor_under(smoke, slab_mesh(1.0, 0.5), 1.5);
    let scene = Scene::build(desc).unwrap();
    let grey = CoefficientSpectrum::new(Vec3::splat(sigma_a));
    let at = |x: f32| {
        let mut v = Vec::new();
        radiance_per_wavelength(
            &scene,
            Ray::new(Vec3::new(x, 0.3, 0.5), Vec3::NEG_Z),
            |w, r| {
                v.push((grey.sample(w)[0], r[0]));
            },
        );
        v
    };
    for ((s, shaded), (_, lit)) in at(0.2).into_iter().zip(at(3.0)) {
        assert!(lit > 0.1, "{lit}");
        let expected = (-s * 0.5).exp();
        assert!(
            (shaded / lit - expected).abs() < 1e-3,
            "shadow ratio {} vs {expected}",
            shaded / lit
        );
    }
}

/// Single scattering (max depth 1) in a wide slab lit by a sun at 36.9 degrees from the
/// vertical, seen straight down: L = sigma_s p(theta) E (1 - exp(-sigma_t d k)) / (sigma_t k),
/// k = 1 + 1 / cos(theta_sun), per wavelength, with chromatic coefficients (the distance is
/// sampled with the hero's extinction; the other wavelengths carry density ratios). E comes
/// from a white Lambertian floor under the same sun.
#[test]
fn single_scattering_in_a_sunlit_slab_matches_the_closed_form() {
    let (sigma_a, sigma_s, g, depth) = (
        Vec3::new(0.2, 0.5, 0.9),
        Vec3::new(1.2, 0.7, 0.3),
        0.4f32,
        0.8f32,
    );
    let light_dir = Vec3::new(0.6, 0.0, -0.8);
    let sun = PunctualLightDesc {
        kind: PunctualKind::Directional,
        direction: light_dir,
        intensity: 2.0,
        color: Vec3::ONE,
        ..Default::default()
    };
    let cloud = volume_only(
        "cloud",
        VolumeDesc {
            sigma_a,
            sigma_s,
            g,
            ..Default::default()
        },
    );
    let mut slab = slab_scene(cloud, depth, 0.0);
    slab.meshes = vec![slab_mesh(50.0, depth)];
    slab.lights = vec![sun.clone()];
    let floor_desc = SceneDesc {
        meshes: vec![common::scenes::quad_mesh(
            "floor",
            Vec3::ZERO,
            Vec3::X * 5.0,
            Vec3::Y * 5.0,
            0,
        )],
        instances: vec![instance(0, Mat4::IDENTITY)],
        materials: vec![common::scenes::diffuse_material("white", Vec3::ONE)],
        lights: vec![sun],
        camera: Some(camera(5.0, 0.5)),
        world: world(0.0),
        ..Default::default()
    };
    let (slab, floor) = (
        Scene::build(slab).unwrap(),
        Scene::build(floor_desc).unwrap(),
    );
    let slab_tracer = PathTracer::new(&slab, 1, LightSelection::Power);
    let floor_tracer = PathTracer::new(&floor, 1, LightSelection::Power);
    let down = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z);
    let (sa, ss) = (
        CoefficientSpectrum::new(sigma_a),
        CoefficientSpectrum::new(sigma_s),
    );
    let cos_sun = 0.8f32;
    let k = 1.0 + 1.0 / cos_sun;
    let phase = prism::media::phase::hg_phase(light_dir.dot(-Vec3::NEG_Z), g);
    let n = 40_000;
    let (mut ratio_sum, mut count) = (0.0f64, 0u32);
    for i in 0..n {
        let w =
            SampledWavelengths::sample_hero((i as f32 + 0.5) / n as f32, WavelengthPdf::Visible);
        let mut sampler = Sampler::new(i as u64, 0, 11);
        let l = slab_tracer.radiance(down, &w, &mut sampler).radiance;
        let e = floor_tracer
            .radiance(down, &w, &mut Sampler::new(0, 0, 1))
            .radiance
            * (std::f32::consts::PI / cos_sun);
        let (sa, ss) = (sa.sample(&w), ss.sample(&w));
        for j in 0..4 {
            let st = sa[j] + ss[j];
            let expected = ss[j] * phase * e[j] * (1.0 - (-st * depth * k).exp()) / (st * k);
            ratio_sum += (l[j] / expected) as f64;
            count += 1;
        }
    }
    let ratio = ratio_sum / count as f64;
    eprintln!("single scattering / closed form = {ratio}");
    assert!(
        (ratio - 1.0).abs() < 0.01,
        "single scattering / closed form = {ratio}"
    );
}

fn scattering_sphere(volume: VolumeDesc, glass: bool) -> SceneDesc {
    let material = if glass {
        MaterialDesc {
            volume: Some(volume),
            ..glass_material("glass", IorDesc::Constant(1.5), 0.0)
        }
    } else {
        volume_only("cloud", volume)
    };
    furnace_scene(material, Vec3::ONE)
}

/// White furnace: a non-absorbing volume (chromatic sigma_s, forward scattering) in a uniform
/// white world neither adds nor removes light, behind no surface and behind smooth glass
/// (which keeps energy too): every pixel is 1 within the noise; an absorbing one is darker.
#[test]
fn scattering_volumes_in_a_white_furnace() {
    let clear = VolumeDesc {
        sigma_s: Vec3::new(3.0, 1.5, 0.6),
        g: 0.6,
        ..Default::default()
    };
    for glass in [false, true] {
        let (mean, px) = render_mean(scattering_sphere(clear.clone(), glass), 24, 64, 10_000, 3);
        eprintln!("glass {glass}: {mean}");
        assert!(
            (mean - Vec3::ONE).abs().max_element() < 0.01,
            "glass {glass}: furnace mean {mean}"
        );
        // No bright or dark outliers either (64 spp of spectral noise: rms about 0.06).
        let rms = (px
            .iter()
            .map(|p| (p[0] - 1.0).powi(2) + (p[2] - 1.0).powi(2))
            .sum::<f32>()
            / (2 * px.len()) as f32)
            .sqrt();
        let worst = px
            .iter()
            .map(|p| (p[0] - 1.0).abs().max((p[2] - 1.0).abs()))
            .fold(0.0f32, f32::max);
        eprintln!("glass {glass}: rms {rms}, worst {worst}");
        assert!(
            rms < 0.1 && worst < 0.6,
            "glass {glass}: rms {rms}, worst {worst}"
        );
    }
    let murky = VolumeDesc {
        sigma_a: Vec3::splat(0.5),
        ..clear
    };
    let (mean, _) = render_mean(scattering_sphere(murky, false), 24, 32, 10_000, 3);
    assert!(
        mean.max_element() < 0.95 && mean.min_element() > 0.2,
        "{mean}"
    );
}

#[test]
fn volume_json_is_parsed_and_checked() {
    use prism::scene::materials_json::parse_materials_json;
    let ok = parse_materials_json(
        r#"{"version":1,"materials":{"Fog":{"volume":{"sigma_s":[0.5,0.5,0.5],"sigma_a":[0.1,0.2,0.3],"g":0.3,"emission":[0,0,1]},"surface":"none"}}}"#,
        "m.json",
        None,
    )
    .unwrap();
    let (name, v, null_surface) = &ok.volumes[0];
    assert_eq!(name, "Fog");
    assert!(*null_surface);
    assert_eq!(v.sigma_a, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(v.g, 0.3);
    assert_eq!(v.color_zero, None);
    let painted = parse_materials_json(
        r#"{"version":1,"materials":{"Fog":{"volume":{"sigma_s":[1,1,1],"color_zero":{"sigma_a":[2,3,4]}}}}}"#,
        "m.json",
        None,
    )
    .unwrap();
    assert_eq!(
        painted.volumes[0].1.color_zero,
        Some((Vec3::new(2.0, 3.0, 4.0), Vec3::ZERO))
    );
    for (json, needle) in [
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{"color_zero":{"sigma_s":[1,-1,1]}}}}}"#,
            "materials.Fog.volume.color_zero.sigma_s[1]: must be non-negative",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{"color_zero":{"g":0.5}}}}}"#,
            "materials.Fog.volume.color_zero",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{"sigma_s":[0.5,-1,0.5]}}}}"#,
            "materials.Fog.volume.sigma_s[1]: must be non-negative",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{"g":1.0}}}}"#,
            "materials.Fog.volume.g: must be in (-1, 1)",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"surface":"none","holdout":true}}}"#,
            "materials.Fog.surface",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{"density":1}}}}"#,
            "density",
        ),
        (
            r#"{"version":1,"materials":{"Fog":{"volume":{},"subsurface":{"preset":"Skin1"}}}}"#,
            "not both",
        ),
    ] {
        let err = parse_materials_json(json, "m.json", None)
            .unwrap_err()
            .to_string();
        assert!(err.contains(needle), "{err}");
        assert!(!err.contains('\n'), "{err}");
    }
}

/// RGB coefficients reproduce per-channel Beer-Lambert (what Blender users see in Cycles and
/// EEVEE) through about one mean free path, and stay close at other depths
/// (`prism::media::CoefficientSpectrum`).
#[test]
fn rgb_absorption_is_close_to_per_channel_beer_lambert() {
    let sigma_a = Vec3::new(0.12, 0.72, 0.96);
    for (d, tolerance) in [(0.5f32, 0.03), (1.6, 0.04), (4.0, 0.15)] {
        let ink = volume_only(
            "ink",
            VolumeDesc {
                sigma_a,
                ..Default::default()
            },
        );
        let (mean, _) = render_mean(slab_scene(ink, d, 1.0), 8, 64, 8, 1);
        let rgb = (-sigma_a * d).exp();
        let ratio = mean / rgb;
        eprintln!("depth {d}: {mean} vs per-channel {rgb}: ratio {ratio}");
        assert!(
            (ratio - Vec3::ONE).abs().max_element() < tolerance,
            "depth {d}: ratio {ratio}"
        );
    }
}

/// A graph binding `input` (a material input's name) to `value` (a JSON value or link) over
/// `nodes`.
fn graph_with(
    nodes: serde_json::Value,
    input: &str,
    value: serde_json::Value,
) -> std::sync::Arc<prism::shading::ShadingGraph> {
    use prism::shading::parse::{parse_graph, NoImages};
    let v = serde_json::json!({"version": 1, "nodes": nodes, "inputs": {input: value}});
    std::sync::Arc::new(
        parse_graph(&v, "graph", &mut NoImages)
            .ok()
            .expect("graph parses"),
    )
}

/// A graph whose `volume_density` is `density` (a JSON value or link) over `nodes`.
fn density_graph(
    nodes: serde_json::Value,
    density: serde_json::Value,
) -> std::sync::Arc<prism::shading::ShadingGraph> {
    graph_with(nodes, "volume_density", density)
}

/// The slab of `slab_scene` (depth 1) crossed along x through its middle and straight down at
/// x = 1 transmits exp(-sigma tau) for optical depths (in units of `spectrum`) `along_x` and
/// `down`.
fn slab_transmits(scene: &Scene, spectrum: &CoefficientSpectrum, along_x: f32, down: f32) {
    mean_transmittance(
        scene,
        Ray::new(Vec3::new(-3.0, 0.1, -0.5), Vec3::X),
        80_000,
        |w| spectrum.sample(w).map(|s| (-s * along_x).exp()).0,
    );
    mean_transmittance(
        scene,
        Ray::new(Vec3::new(1.0, 0.2, 5.0), Vec3::NEG_Z),
        80_000,
        |w| spectrum.sample(w).map(|s| (-s * down).exp()).0,
    );
}

/// An absorbing volume (no surface) whose density is its Generated X coordinate: 0 to 1
/// across the object's box.
fn absorbing_along_x(name: &str, sigma_a: Vec3) -> MaterialDesc {
    let mut m = volume_only(
        name,
        VolumeDesc {
            sigma_a,
            ..Default::default()
        },
    );
    m.graph = Some(density_graph(
        serde_json::json!({
            "TC": {"type": "tex_coord"},
            "Sep": {"type": "separate_xyz", "inputs": {"vector": {"node": "TC", "output": "generated"}}}
        }),
        serde_json::json!({"node": "Sep", "output": "x"}),
    ));
    m
}

/// Mean radiance (over `n` samples at 16 wavelength sets) along `ray`, per wavelength, divided
/// by the white world's.
fn mean_transmittance(
    scene: &Scene,
    ray: Ray,
    n: u32,
    f: impl Fn(&SampledWavelengths) -> [f32; 4],
) {
    let tracer = PathTracer::new(scene, 64, LightSelection::Power);
    let world = RgbIlluminantSpectrum::new(Vec3::ONE);
    let (mut sum, mut expected) = (0.0f64, 0.0f64);
    for i in 0..n {
        let w =
            SampledWavelengths::sample_hero(((i % 16) as f32 + 0.5) / 16.0, WavelengthPdf::Visible);
        let mut sampler = Sampler::new(i as u64, 0, 5);
        let r = tracer
            .radiance(ray, &w, &mut sampler)
            .radiance
            .safe_div(world.sample(&w));
        let e = f(&w);
        for k in 0..4 {
            sum += r[k] as f64;
            expected += e[k] as f64;
        }
    }
    let ratio = sum / expected;
    eprintln!("tracked / analytic transmittance = {ratio}");
    assert!((ratio - 1.0).abs() < 0.01, "tracked / analytic = {ratio}");
}

/// Heterogeneous volumes: a density rising linearly across the slab (Generated X, from 0 at
/// x = -2 to 1 at x = 2). A ray along x crosses optical depth sigma_a * 2; one along z at x
/// sees density (x + 2) / 4 all the way down. Camera rays use delta tracking (an absorbing
/// collision ends the path), so the mean over many paths is the transmittance.
#[test]
fn heterogeneous_density_tracks_its_optical_depth() {
    let sigma_a = Vec3::new(0.9, 0.5, 0.3);
    let ink = absorbing_along_x("ink", sigma_a);
    let scene = Scene::build(slab_scene(ink, 1.0, 1.0)).unwrap();
    // Along x through the middle of the slab (z = -0.5): integral of (x + 2) / 4 over 4 units
    // = 2; straight down at x = 1: density 0.75 through depth 1.
    slab_transmits(&scene, &CoefficientSpectrum::new(sigma_a), 2.0, 0.75);
}

/// A sun-lit heterogeneous slab: shadow rays through it use ratio tracking. The floor under
/// the slab at x = 1 receives the sun through density 0.75.
#[test]
fn heterogeneous_shadows_use_ratio_tracking() {
    let sigma_a = Vec3::splat(1.2);
    let smoke = absorbing_along_x("smoke", sigma_a);
    let desc = sunlit_floor_under(smoke, slab_mesh(2.0, 0.5), 2.0);
    let scene = Scene::build(desc).unwrap();
    let tracer = PathTracer::new(&scene, 1, LightSelection::Power);
    let mean_at = |x: f32| {
        let mut sum = 0.0f64;
        for i in 0..40000u32 {
            let w =
                SampledWavelengths::sample_hero((i as f32 + 0.5) / 40000.0, WavelengthPdf::Visible);
            let mut sampler = Sampler::new(i as u64, 1, 9);
            let r = tracer
                .radiance(
                    Ray::new(Vec3::new(x, 0.3, 0.5), Vec3::NEG_Z),
                    &w,
                    &mut sampler,
                )
                .radiance;
            sum += r.average() as f64;
        }
        sum / 40000.0
    };
    let (shaded, lit) = (mean_at(1.0), mean_at(3.0));
    let expected = (-1.2f64 * 0.5 * 0.75).exp();
    eprintln!("shadow ratio {} vs {expected}", shaded / lit);
    assert!(
        (shaded / lit - expected).abs() < 0.01,
        "{} vs {expected}",
        shaded / lit
    );
}

/// White furnace with a textured density: a non-absorbing cloud whose density follows a Noise
/// texture (delta tracking with null collisions, phase sampling, ratio-tracked shadow rays)
/// neither adds nor removes light.
#[test]
fn heterogeneous_scattering_cloud_in_a_white_furnace() {
    let mut cloud = volume_only(
        "cloud",
        VolumeDesc {
            sigma_s: Vec3::new(6.0, 3.0, 1.5),
            g: 0.5,
            ..Default::default()
        },
    );
    cloud.graph = Some(density_graph(
        serde_json::json!({
            "Noise": {"type": "noise_texture", "inputs": {"scale": 3.0, "detail": 2.0}}
        }),
        serde_json::json!({"node": "Noise", "output": "fac"}),
    ));
    let (mean, _) = render_mean(furnace_scene(cloud, Vec3::ONE), 24, 64, 10_000, 3);
    eprintln!("heterogeneous furnace: {mean}");
    assert!((mean - Vec3::ONE).abs().max_element() < 0.01, "{mean}");
}

/// A textured volume colour: coefficients `volume.sigma_*` where it is white and
/// `volume.color_zero` where it is black, per wavelength in between. Here Volume Absorption's
/// form, sigma_a = (1 - c) A, with the colour grey and equal to Generated X (0 to 1 across the
/// slab, density 1): along x the optical depth is A times the integral of 1 - (x + 2) / 4 over
/// 4 units, 2 A; straight down at x = 1, c = 0.75 and depth 1 give 0.25 A. Without the colour
/// field (the constant white end) the slab would be clear, and with the white end's majorant
/// (0) no collision would be tried.
#[test]
fn textured_volume_colour_mixes_the_two_ends() {
    let absorption = Vec3::new(0.9, 0.5, 0.3);
    let mut ink = volume_only(
        "ink",
        VolumeDesc {
            color_zero: Some((absorption, Vec3::ZERO)),
            ..Default::default()
        },
    );
    ink.graph = Some(graph_with(
        serde_json::json!({
            "TC": {"type": "tex_coord"},
            "Sep": {"type": "separate_xyz", "inputs": {"vector": {"node": "TC", "output": "generated"}}},
            "Grey": {"type": "combine_color", "inputs": {
                "red": {"node": "Sep", "output": "x"},
                "green": {"node": "Sep", "output": "x"},
                "blue": {"node": "Sep", "output": "x"}}}
        }),
        "volume_color",
        serde_json::json!({"node": "Grey", "output": "color"}),
    ));
    let scene = Scene::build(slab_scene(ink, 1.0, 1.0)).unwrap();
    slab_transmits(&scene, &CoefficientSpectrum::new(absorption), 2.0, 0.25);
}

/// White furnace with a textured colour: a non-absorbing cloud whose sigma_s is three times
/// larger where its colour (a Noise texture's, density 1) is black than where it is white:
/// the extinction varies with the colour alone (null collisions under the larger end's
/// majorant), and the furnace stays 1.
#[test]
fn textured_volume_colour_in_a_white_furnace() {
    let mut cloud = volume_only(
        "cloud",
        VolumeDesc {
            sigma_s: Vec3::new(2.0, 1.0, 0.5),
            g: 0.5,
            color_zero: Some((Vec3::ZERO, Vec3::new(6.0, 3.0, 1.5))),
            ..Default::default()
        },
    );
    cloud.graph = Some(graph_with(
        serde_json::json!({"Noise": {"type": "noise_texture", "inputs": {"scale": 3.0, "detail": 2.0}}}),
        "volume_color",
        serde_json::json!({"node": "Noise", "output": "color"}),
    ));
    let (mean, _) = render_mean(furnace_scene(cloud, Vec3::ONE), 24, 64, 10_000, 3);
    eprintln!("textured-colour furnace: {mean}");
    assert!((mean - Vec3::ONE).abs().max_element() < 0.01, "{mean}");
}
