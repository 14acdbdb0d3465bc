//! Light selection: the light tree's choices follow its own pmf (chi-square), also where the
//! sampling splits into the tree's choice and every distant light, the density of a
//! light that a BSDF ray hits equals the density with which light sampling produces that
//! direction from the same shading point (so MIS weights sum to one), and on 1000 small
//! emitters the tree beats power-proportional selection by a wide margin at equal spp.

mod common;
#[path = "common/stats.rs"]
mod stats;

use common::scenes::{
    diffuse_material, emissive_material, mean_rgb, quad_mesh, rel_mse, render_rgba,
};
use glam::{Mat4, Vec2, Vec3};
use prism::geometry::Ray;
use prism::lights::{Light, LightSelection, ShadingContext};
use prism::render::RenderSettings;
use prism::sampler::Pcg32;
use prism::scene::{
    EnvironmentTextureDesc, InstanceDesc, PunctualKind, PunctualLightDesc, Scene, SceneDesc,
    WorldDesc,
};
use prism::spectrum::SampledWavelengths;

/// A floor at y = 0 seen from above, and `n` small square emitters facing down (one-sided)
/// spread over it at heights 0.3-2, with powers spanning two decades; plus, optionally, a
/// point light, a spot, a sun with a disc and an environment map.
fn many_emitters(n: usize, extras: bool) -> SceneDesc {
    let mut rng = Pcg32::new(1, 2, 3);
    let mut meshes = vec![quad_mesh(
        "floor",
        Vec3::ZERO,
        Vec3::X * 10.0,
        Vec3::Z * -10.0,
        0,
    )];
    let mut materials = vec![diffuse_material("floor", Vec3::splat(0.5))];
    for i in 0..n {
        let c = Vec3::new(
            (rng.next_1d() - 0.5) * 19.0,
            0.3 + 1.7 * rng.next_1d(),
            (rng.next_1d() - 0.5) * 19.0,
        );
        let s = 0.03 + 0.05 * rng.next_1d();
        let strength = 10f32.powf(1.0 + 2.0 * rng.next_1d());
        let colour = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 0.8 + 0.2;
        materials.push(emissive_material(
            &format!("e{i}"),
            colour * strength,
            false,
        ));
        // Normal (u x v = x x z = -y) pointing down: the front face lights the floor. Every
        // third emitter is a disc (a fan of triangles, as Blender's disc area lights).
        meshes.push(if i % 3 == 2 {
            disc_mesh(&format!("e{i}"), c, s, 12, i + 1)
        } else {
            quad_mesh(&format!("e{i}"), c, Vec3::X * s, Vec3::Z * s, i + 1)
        });
    }
    let mut cam = common::scenes::camera(0.0, 1.2);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 12.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    // The discs are area lights, as the add-on writes them (`Light::FlatEmitter`).
    let instance_visibility = (0..meshes.len())
        .map(|i| prism::scene::InstanceVisibility {
            light_only: i > 0 && (i - 1) % 3 == 2,
            ..Default::default()
        })
        .collect();
    let mut desc = SceneDesc {
        instance_visibility,
        instances: (0..meshes.len())
            .map(|i| InstanceDesc {
                mesh: i,
                object_to_world: Mat4::IDENTITY,
                name: format!("i{i}"),
            })
            .collect(),
        meshes,
        materials,
        camera: Some(cam),
        ..Default::default()
    };
    if extras {
        let light = |kind, intensity, position, direction, angle| PunctualLightDesc {
            name: "l".into(),
            kind,
            color: Vec3::new(1.0, 0.9, 0.8),
            intensity,
            position,
            direction,
            angle,
            ..Default::default()
        };
        desc.lights = vec![
            light(
                PunctualKind::Point,
                30.0,
                Vec3::new(2.0, 1.0, 1.0),
                Vec3::NEG_Y,
                0.0,
            ),
            light(
                PunctualKind::Spot {
                    inner_cone: 0.3,
                    outer_cone: 0.6,
                },
                50.0,
                Vec3::new(-3.0, 2.0, 0.0),
                Vec3::new(0.3, -1.0, 0.1).normalize(),
                0.0,
            ),
            light(
                PunctualKind::Directional,
                2.0,
                Vec3::ZERO,
                Vec3::new(0.4, -1.0, 0.3).normalize(),
                0.2,
            ),
        ];
        // A small environment map: a bright patch on a dim sky.
        let (w, h) = (32u32, 16u32);
        let texels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (4..7).contains(&x) && (3..5).contains(&y) {
                    Vec3::new(20.0, 18.0, 15.0)
                } else {
                    Vec3::new(0.2, 0.3, 0.5)
                }
            })
            .collect();
        desc.world = WorldDesc {
            color: Vec3::ONE,
            strength: 1.0,
            texture: Some(EnvironmentTextureDesc {
                name: "sky".into(),
                width: w,
                height: h,
                texels,
                rotation_z: 0.0,
            }),
        };
    }
    desc
}

/// Shading points on the floor (reflecting: normal +y) and in the air (no normal).
/// A disc of `radius` about `c` in the plane y = c.y facing down, as a fan of `segments`
/// triangles around its centre.
fn disc_mesh(
    name: &str,
    c: Vec3,
    radius: f32,
    segments: u32,
    material: usize,
) -> prism::scene::MeshDesc {
    let mut positions = vec![c];
    for k in 0..segments {
        let a = std::f32::consts::TAU * k as f32 / segments as f32;
        positions.push(c + radius * (Vec3::X * a.cos() + Vec3::Z * a.sin()));
    }
    // (centre, p_k, p_k+1): (x cos + z sin) x (x cos' + z sin') is sin(a' - a) (x x z), down.
    let indices = (0..segments)
        .flat_map(|k| [0, k + 1, (k + 1) % segments + 1])
        .collect();
    prism::scene::MeshDesc {
        name: name.into(),
        positions,
        indices,
        material: Some(material),
        ..Default::default()
    }
}

fn contexts(n: usize) -> Vec<ShadingContext> {
    let mut rng = Pcg32::new(9, 9, 9);
    (0..n)
        .map(|i| {
            let p = Vec3::new(
                (rng.next_1d() - 0.5) * 18.0,
                if i % 3 == 0 { 0.8 * rng.next_1d() } else { 0.0 },
                (rng.next_1d() - 0.5) * 18.0,
            );
            ShadingContext {
                p,
                n: (i % 3 != 0).then_some(Vec3::Y),
                time: 0.5,
            }
        })
        .collect()
}

#[test]
fn light_choices_follow_the_pmf() {
    let scene = Scene::build(many_emitters(60, true)).expect("scene builds");
    let lights = &scene.lights;
    let n_lights = lights.len();
    let mut failures = Vec::new();
    for ctx in contexts(6) {
        let pmf: Vec<f64> = (0..n_lights)
            .map(|i| lights.pmf(&ctx, i, LightSelection::TreeSingle) as f64)
            .collect();
        let total: f64 = pmf.iter().sum();
        assert!(total <= 1.0 + 1e-4, "pmf sums to {total} at {:?}", ctx.p);
        let draws = 200_000;
        // The last cell: no light chosen (a tree node whose bounds reach the point while
        // none of its children's do), with probability 1 - sum(pmf).
        let mut counts = vec![0f64; n_lights + 1];
        let mut rng = Pcg32::new(5, 6, 7);
        for _ in 0..draws {
            match lights.select(&ctx, rng.next_1d(), LightSelection::TreeSingle) {
                Some((i, p)) => {
                    // The returned probability is the pmf.
                    let want = pmf[i];
                    assert!(
                        (p as f64 - want).abs() <= 1e-5 + 1e-4 * want,
                        "light {i}: {p} vs {want}"
                    );
                    counts[i] += 1.0;
                }
                None => counts[n_lights] += 1.0,
            }
        }
        for i in 0..n_lights {
            assert!(
                pmf[i] > 0.0 || counts[i] == 0.0,
                "light {i} drawn with pmf 0"
            );
        }
        let mut expected: Vec<f64> = pmf.iter().map(|p| p * draws as f64).collect();
        expected.push((1.0 - total).max(0.0) * draws as f64);
        failures.push(1.0 - total);
        let p = stats::chi2_test(&counts, &expected, 5.0).p_value;
        assert!(p > 1e-4, "chi-square p = {p:.2e} at {:?}", ctx.p);
    }
    // Failed descents are rare: they waste light samples.
    println!("probability of choosing no light: {failures:?}");
    assert!(failures.iter().all(|&f| f < 0.02), "{failures:?}");
}

/// One next-event estimation's light samples at `ctx` from `rng`'s numbers.
fn random_light_samples(
    scene: &Scene,
    ctx: &ShadingContext,
    rng: &mut Pcg32,
    w: &SampledWavelengths,
    selection: LightSelection,
) -> [Option<prism::lights::LightSample>; 1 + prism::lights::MAX_SPLIT_DISTANT] {
    scene.lights.sample(
        &scene.geometry,
        &scene.materials,
        ctx,
        rng.next_1d(),
        Vec2::new(rng.next_1d(), rng.next_1d()),
        w,
        selection,
    )
}

#[test]
fn split_sampling_takes_every_distant_light_and_the_tree_choice_follows_its_pmf() {
    // With the sun and the sky besides the lamps, the default selection gives each distant
    // light a sample of its own (probability 1) and chooses among the tree's lights with the
    // single choice's probabilities renormalised to the tree; `pmf` says so for MIS.
    let scene = Scene::build(many_emitters(60, true)).expect("scene builds");
    let lights = &scene.lights;
    let n_lights = lights.len();
    let distant = |i: usize| {
        matches!(
            lights.light(i),
            Light::Directional { .. } | Light::Environment
        )
    };
    let mut split_contexts = 0;
    for ctx in contexts(6) {
        let single: Vec<f64> = (0..n_lights)
            .map(|i| lights.pmf(&ctx, i, LightSelection::TreeSingle) as f64)
            .collect();
        let split: Vec<f64> = (0..n_lights)
            .map(|i| lights.pmf(&ctx, i, LightSelection::Tree) as f64)
            .collect();
        let distant_share: f64 = (0..n_lights)
            .filter(|&i| distant(i))
            .map(|i| single[i])
            .sum();
        if !(distant_share > 0.0 && distant_share < 1.0) {
            // Only one of the tree and the distant lights reaches the point: no split.
            for i in 0..n_lights {
                assert!(
                    (split[i] - single[i]).abs() <= 1e-6,
                    "light {i} at {:?}",
                    ctx.p
                );
            }
            continue;
        }
        split_contexts += 1;
        for i in 0..n_lights {
            let want = match distant(i) {
                true if single[i] > 0.0 => 1.0,
                true => 0.0,
                false => single[i] / (1.0 - distant_share),
            };
            assert!(
                (split[i] - want).abs() <= 1e-5 + 1e-4 * want,
                "light {i} at {:?}: pmf {} vs {want}",
                ctx.p,
                split[i]
            );
        }
        // The tree's choices follow that pmf (the last cell: no light chosen).
        let draws = 100_000;
        let mut counts = vec![0f64; n_lights + 1];
        let mut rng = Pcg32::new(5, 6, 7);
        for _ in 0..draws {
            match lights.select(&ctx, rng.next_1d(), LightSelection::Tree) {
                Some((i, p)) => {
                    assert!(!distant(i), "the split choice returned distant light {i}");
                    assert!((p as f64 - split[i]).abs() <= 1e-5 + 1e-4 * split[i]);
                    counts[i] += 1.0;
                }
                None => counts[n_lights] += 1.0,
            }
        }
        let local: Vec<usize> = (0..n_lights).filter(|&i| !distant(i)).collect();
        let mut observed: Vec<f64> = local.iter().map(|&i| counts[i]).collect();
        let mut expected: Vec<f64> = local.iter().map(|&i| split[i] * draws as f64).collect();
        observed.push(counts[n_lights]);
        expected.push((draws as f64 - expected.iter().sum::<f64>()).max(0.0));
        let p = stats::chi2_test(&observed, &expected, 5.0).p_value;
        assert!(p > 1e-4, "chi-square p = {p:.2e} at {:?}", ctx.p);
        // Every light sample set holds each distant light that can light the point.
        let w = SampledWavelengths::sample_hero(0.3, Default::default());
        for _ in 0..200 {
            let samples = random_light_samples(&scene, &ctx, &mut rng, &w, LightSelection::Tree);
            for i in (0..n_lights).filter(|&i| distant(i) && split[i] > 0.0) {
                let taken = samples.iter().flatten().filter(|ls| ls.light == i).count();
                // The map's sample fails where its texel is black (none here).
                assert_eq!(
                    taken, 1,
                    "distant light {i} sampled {taken} times at {:?}",
                    ctx.p
                );
            }
        }
    }
    assert!(split_contexts >= 2, "{split_contexts} contexts split");

    // Above the emitters (which face down), with the point and spot lights gone, only the sun
    // and the sky reach the point: they split, the tree is not sampled, and an emitter a BSDF
    // ray might still hit has probability 0 (not 0 / 0).
    let mut desc = many_emitters(10, true);
    desc.lights
        .retain(|l| matches!(l.kind, PunctualKind::Directional));
    let scene = Scene::build(desc).expect("scene builds");
    let lights = &scene.lights;
    let above = ShadingContext {
        p: Vec3::new(0.0, 5.0, 0.0),
        n: Some(Vec3::Y),
        time: 0.5,
    };
    let mut distant_pmfs = Vec::new();
    for i in 0..lights.len() {
        let p = lights.pmf(&above, i, LightSelection::Tree);
        match matches!(
            lights.light(i),
            Light::Directional { .. } | Light::Environment
        ) {
            true => distant_pmfs.push(p),
            false => assert_eq!(p, 0.0, "emitter {i} at a point it cannot light"),
        }
    }
    assert_eq!(distant_pmfs, vec![1.0, 1.0]);
}

#[test]
fn a_wrong_pmf_fails_the_chi_square() {
    // The test above can fail: the same draws against a flattened pmf are rejected.
    let scene = Scene::build(many_emitters(60, true)).expect("scene builds");
    let lights = &scene.lights;
    let ctx = contexts(2)[1];
    let n = lights.len();
    let mut counts = vec![0f64; n];
    let mut rng = Pcg32::new(1, 1, 1);
    let draws = 100_000;
    for _ in 0..draws {
        if let Some((i, _)) = lights.select(&ctx, rng.next_1d(), LightSelection::TreeSingle) {
            counts[i] += 1.0;
        }
    }
    let expected = vec![draws as f64 / n as f64; n];
    assert!(stats::chi2_test(&counts, &expected, 5.0).p_value < 1e-6);
}

#[test]
fn a_hit_light_has_the_density_that_sampled_it() {
    // For every light sample, the integrator's density of reaching that direction by hitting
    // the light (triangle_pdf / infinite_pdf, what MIS uses for BSDF samples) equals the
    // density light sampling reported. Then the power-heuristic weights of the two techniques
    // sum to one for any BSDF density.
    let scene = Scene::build(many_emitters(40, true)).expect("scene builds");
    let lights = &scene.lights;
    let w = SampledWavelengths::sample_hero(0.3, Default::default());
    let mut rng = Pcg32::new(3, 1, 4);
    let mut checked = [0usize; 3];
    let mut flat_checked = 0usize;
    let mut split = 0usize;
    let selections = [
        LightSelection::Tree,
        LightSelection::TreeSingle,
        LightSelection::Power,
    ];
    for selection in selections {
        for ctx in contexts(30) {
            for _ in 0..40 {
                let samples = random_light_samples(&scene, &ctx, &mut rng, &w, selection);
                split += usize::from(samples.iter().flatten().count() > 1);
                for ls in samples.into_iter().flatten() {
                    let chosen = ls.light;
                    // Delta lights cannot be hit; at the map's poles its density (1 / sin theta)
                    // is too ill-conditioned in f32 to compare.
                    if ls.delta || ls.wi.y.abs() > 0.9999 {
                        continue;
                    }
                    let origin = ctx.p + ls.wi * 1e-4;
                    let density = match scene
                        .geometry
                        .intersect(&Ray::new(origin, ls.wi), f32::INFINITY)
                    {
                        Some(hit) if ls.distance.is_finite() => {
                            // Near a shared edge the ray may hit the neighbouring triangle, whose
                            // selection probability differs: compare the sampled one only.
                            let same = match lights.light(chosen) {
                                Light::Triangle { instance, prim } => {
                                    *instance == hit.instance && *prim == hit.prim
                                }
                                // Any triangle of a pair or a flat emitter is the same light.
                                Light::TrianglePair { instance, .. }
                                | Light::FlatEmitter { instance, .. } => *instance == hit.instance,
                                _ => false,
                            };
                            if !same {
                                continue;
                            }
                            let sp = scene.geometry.surface_point(&hit);
                            let cos = sp.ng.dot(-ls.wi);
                            checked[0] += 1;
                            flat_checked += usize::from(matches!(
                                lights.light(chosen),
                                Light::FlatEmitter { .. }
                            ));
                            lights.triangle_pdf(
                                &scene.geometry,
                                &ctx,
                                hit.instance,
                                hit.prim,
                                sp.area,
                                hit.t + 1e-4,
                                cos,
                                selection,
                            )
                        }
                        Some(_) => continue, // an occluded sun or sky sample
                        None => {
                            // Each light at infinity is its own technique (the sun disc lies in
                            // the sky): the one sampled must be among those seen, with the same
                            // density.
                            let mut seen = false;
                            lights.for_each_at_infinity(ls.wi, &w, |i, _| seen |= i == chosen);
                            assert!(seen, "light {chosen} not seen along its own sample");
                            let sky = matches!(lights.light(chosen), Light::Environment);
                            checked[if sky { 1 } else { 2 }] += 1;
                            lights.infinite_pdf(&ctx, chosen, ls.wi, selection)
                        }
                    };
                    assert!(
                    (density - ls.pdf).abs() <= 2e-3 * ls.pdf,
                    "{selection:?} at {:?}: hit density {density} vs sampled {} (light {:?}, {:?})",
                    ctx.p,
                    ls.pdf,
                    lights.light(chosen),
                    ls.wi
                );
                    let bsdf = rng.next_1d() * 2.0;
                    let (wl, wb) = (
                        prism::math::power_heuristic(ls.pdf, bsdf),
                        prism::math::power_heuristic(bsdf, density),
                    );
                    assert!((wl + wb - 1.0).abs() < 1e-3);
                }
            }
        }
    }
    assert!(
        checked.iter().all(|&c| c > 20),
        "triangles, sky, sun checked: {checked:?}"
    );
    // The default selection split the sampling at most points (the lamps, the sun, the sky).
    assert!(split > 500, "{split} split next-event estimations");
    // Discs are one light each (`Light::FlatEmitter`), and were checked.
    assert!(flat_checked > 20, "{flat_checked} disc samples checked");
}

/// A `size` x `size` render of `scene` with paths of at most `max_depth` bounces (no
/// non-finite sample allowed), as RGBA.
fn render_square(
    scene: &Scene,
    size: u32,
    max_depth: u32,
    selection: LightSelection,
    spp: u32,
    seed: u64,
) -> Vec<[f32; 4]> {
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth,
        seed,
        light_selection: selection,
        ..Default::default()
    };
    render_rgba(scene, &settings)
}

#[test]
fn the_tree_beats_power_selection_on_1000_emitters() {
    let scene = Scene::build(many_emitters(1000, false)).expect("scene builds");
    let render = |selection, spp, seed| render_square(&scene, 48, 1, selection, spp, seed);
    let reference = render(LightSelection::Tree, 1024, 77);
    let mean = |selection| -> f64 {
        (1..=2)
            .map(|s| rel_mse(&render(selection, 16, s), &reference))
            .sum::<f64>()
            / 2.0
    };
    let (tree, power) = (mean(LightSelection::Tree), mean(LightSelection::Power));
    println!(
        "16 spp relMSE on 1000 emitters: tree {tree:.3e}, power {power:.3e}, ratio {:.1}",
        power / tree
    );
    assert!(power >= 5.0 * tree, "tree {tree:.3e} vs power {power:.3e}");
}

#[test]
fn splitting_the_distant_lights_keeps_the_image_and_lowers_its_noise() {
    // The lamps, a spot, a sun and a sky over a floor, with the emitters' backs shading it:
    // sampling the sun and the sky besides the tree's choice converges to the same image as
    // one light per point, with less noise at equal samples.
    let scene = Scene::build(many_emitters(40, true)).expect("scene builds");
    let render = |selection, spp, seed| render_square(&scene, 40, 3, selection, spp, seed);
    let reference = render(LightSelection::Tree, 1024, 91);
    let single_reference = render(LightSelection::TreeSingle, 1024, 92);
    let (m_split, m_single) = (
        mean_rgb(&reference).element_sum(),
        mean_rgb(&single_reference).element_sum(),
    );
    println!("image mean: split {m_split:.5}, single {m_single:.5}");
    assert!(
        (m_split / m_single - 1.0).abs() < 0.01,
        "{m_split} vs {m_single}"
    );
    let noise = |selection| -> f64 {
        (1..=3)
            .map(|s| rel_mse(&render(selection, 16, s), &reference))
            .sum::<f64>()
            / 3.0
    };
    let (split, single) = (
        noise(LightSelection::Tree),
        noise(LightSelection::TreeSingle),
    );
    println!(
        "16 spp relMSE: split {split:.3e}, single {single:.3e}, ratio {:.2}",
        single / split
    );
    assert!(
        single >= 2.0 * split,
        "split {split:.3e} vs single {single:.3e}"
    );
}

/// A square emitter of side 1 just above shading points (0.05 away; the top of a Cornell box's
/// walls under its ceiling light): triangles large for their distance are sampled by solid
/// angle. Next-event estimation's irradiance estimate (cos / pdf, unit radiance) averages to
/// Lambert's closed form for a polygon, its relative variance is far below that of sampling
/// the square by area, and the density of hitting each sampled point equals the sampled one
/// (so MIS stays exact).
#[test]
fn large_near_emitters_are_sampled_by_solid_angle() {
    let h = 0.05;
    let panel = quad_mesh(
        "panel",
        Vec3::new(0.0, h, 0.0),
        Vec3::X * 0.5,
        Vec3::Z * 0.5,
        0,
    );
    let corners = [
        Vec3::new(-0.5, h, -0.5),
        Vec3::new(0.5, h, -0.5),
        Vec3::new(0.5, h, 0.5),
        Vec3::new(-0.5, h, 0.5),
    ];
    // Lambert 1760: E / L = 1/2 sum over edges of (edge angle) (n . unit normal of the edge's
    // plane), vertices seen from p.
    let lambert = |p: Vec3, n: Vec3| {
        let r = corners.map(|c| (c - p).normalize());
        (0..4)
            .map(|i| {
                let (a, b) = (r[i], r[(i + 1) % 4]);
                0.5 * a.dot(b).clamp(-1.0, 1.0).acos() * n.dot(a.cross(b).normalize())
            })
            .sum::<f32>()
            .abs()
    };
    let scene = panel_scene(panel);
    let lights = &scene.lights;
    // The panel's two triangles are one light, sampled over its whole solid angle.
    assert_eq!(lights.len(), 1);
    assert!(matches!(lights.light(0), Light::TrianglePair { .. }));
    let w = SampledWavelengths::sample_hero(0.3, Default::default());
    let mut rng = Pcg32::new(5, 6, 7);
    let receivers = [
        (Vec3::ZERO, Vec3::Y),
        (Vec3::new(0.4, 0.0, -0.3), Vec3::Y),
        (
            Vec3::new(0.55, -0.02, 0.1),
            Vec3::new(-1.0, 1.0, 0.0).normalize(),
        ),
    ];
    for (p, n) in receivers {
        let ctx = ShadingContext {
            p,
            n: Some(n),
            time: 0.5,
        };
        let count = 20_000;
        let (mut sum, mut sum2, mut area_sum, mut area_sum2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for _ in 0..count {
            let u = Vec2::new(rng.next_1d(), rng.next_1d());
            let Some((wi, pdf, _)) = sample_meeting_the_emitter(&scene, &ctx, rng.next_1d(), u, &w)
            else {
                continue;
            };
            let cos = n.dot(wi).max(0.0);
            let e = (cos / pdf) as f64;
            sum += e;
            sum2 += e * e;
            // The same estimate with the square sampled uniformly by area.
            let q = Vec3::new(u.x - 0.5, h, u.y - 0.5);
            let d = q - p;
            let e_area = (n.dot(d).max(0.0) * d.y / d.length_squared().powi(2)) as f64;
            area_sum += e_area;
            area_sum2 += e_area * e_area;
        }
        let n_f = count as f64;
        let mean = sum / n_f;
        let want = lambert(p, n) as f64;
        let rel_var = (sum2 / n_f - mean * mean) / (mean * mean);
        let area_mean = area_sum / n_f;
        let area_rel_var = (area_sum2 / n_f - area_mean * area_mean) / (area_mean * area_mean);
        assert!(
            (mean / want - 1.0).abs() < 0.01,
            "at {p}: irradiance {mean} vs Lambert {want}"
        );
        assert!(
            rel_var * 5.0 < area_rel_var,
            "at {p}: relative variance {rel_var} by solid angle vs {area_rel_var} by area"
        );
    }
}

#[test]
fn a_pair_chooses_its_triangle_by_solid_angle_near_and_by_area_far() {
    // A one-sided trapezoid facing down, split along its diagonal a-c into halves of area
    // 0.5 (a b c) and 0.25 (a c d): one light. Its samples must land in each half in proportion
    // to the half's area where the pair is sampled by area (far), and to the solid angle the
    // half subtends where it is sampled by solid angle (near), with the density MIS uses.
    let h = 1.0;
    let (a, b, c, d) = (
        Vec3::new(-0.5, h, -0.5),
        Vec3::new(0.5, h, -0.5),
        Vec3::new(0.25, h, 0.5),
        Vec3::new(-0.25, h, 0.5),
    );
    let mut panel = quad_mesh("panel", Vec3::ZERO, Vec3::X, Vec3::Z, 0);
    panel.positions = vec![a, b, c, d];
    let scene = panel_scene(panel);
    let lights = &scene.lights;
    assert_eq!(lights.len(), 1);
    assert!(matches!(lights.light(0), Light::TrianglePair { .. }));
    let w = SampledWavelengths::sample_hero(0.3, Default::default());
    let mut rng = Pcg32::new(8, 1, 2);
    let solid_angle = |p: Vec3, t: [Vec3; 3]| {
        let [x, y, z] = t.map(|v| (v - p).normalize());
        prism::math::sampling::spherical_triangle_solid_angle(x, y, z)
    };
    // In the half a b c: on the same side of the diagonal a-c as b.
    let in_abc = |q: Vec3| (c - a).cross(q - a).y * (c - a).cross(b - a).y > 0.0;
    let far = Vec3::new(0.1, h - 3.0, 0.2);
    let near = Vec3::new(-0.15, h - 0.08, 0.3);
    let near_share = {
        let (o0, o1) = (solid_angle(near, [a, b, c]), solid_angle(near, [a, c, d]));
        o0 / (o0 + o1)
    };
    // The two expectations differ from each other and from an even split, so a wrong share
    // in either mode fails.
    assert!((near_share - 2.0 / 3.0).abs() > 0.1 && (near_share - 0.5).abs() > 0.1);
    for (p, want) in [(far, 2.0 / 3.0), (near, near_share)] {
        let ctx = ShadingContext {
            p,
            n: Some(Vec3::Y),
            time: 0.5,
        };
        let count = 20_000;
        let mut in_first = 0usize;
        let mut hits = 0usize;
        for _ in 0..count {
            let u = Vec2::new(rng.next_1d(), rng.next_1d());
            let Some((_, _, q)) = sample_meeting_the_emitter(&scene, &ctx, rng.next_1d(), u, &w)
            else {
                continue;
            };
            hits += 1;
            in_first += in_abc(q) as usize;
        }
        assert!(hits > count * 99 / 100, "at {p}: {hits} of {count} samples");
        let share = in_first as f64 / hits as f64;
        // Binomial standard deviation about 0.0034: 0.015 is over 4 of them.
        assert!(
            (share - want as f64).abs() < 0.015,
            "at {p}: {share:.4} of the samples in the larger half, want {want:.4}"
        );
    }
}

/// A light sample from `ctx` in a scene whose one light is an emissive mesh: its direction,
/// density and the point where the direction meets the emitter, after checking that the
/// density MIS gives a BSDF ray hitting the emitter there (`triangle_pdf`) is the sampled one.
fn sample_meeting_the_emitter(
    scene: &Scene,
    ctx: &ShadingContext,
    u_select: f32,
    u: Vec2,
    w: &SampledWavelengths,
) -> Option<(Vec3, f32, Vec3)> {
    let lights = &scene.lights;
    let [ls, ..] = lights.sample(
        &scene.geometry,
        &scene.materials,
        ctx,
        u_select,
        u,
        w,
        LightSelection::Tree,
    );
    let ls = ls?;
    let p = ctx.p;
    let hit = scene
        .geometry
        .intersect(&Ray::new(p, ls.wi), f32::INFINITY)
        .expect("the sample's direction meets the emitter");
    let sp = scene.geometry.surface_point(&hit);
    let density = lights.triangle_pdf(
        &scene.geometry,
        ctx,
        hit.instance,
        hit.prim,
        sp.area,
        hit.t,
        sp.ng.dot(-ls.wi),
        LightSelection::Tree,
    );
    assert!(
        (density - ls.pdf).abs() <= 2e-3 * ls.pdf,
        "at {p}: hit density {density} vs sampled {}",
        ls.pdf
    );
    Some((ls.wi, ls.pdf, sp.p))
}

/// A scene of one emissive `panel` (radiance 1, one-sided) and a camera.
fn panel_scene(panel: prism::scene::MeshDesc) -> Scene {
    Scene::build(panel_desc(panel)).expect("scene builds")
}

fn panel_desc(panel: prism::scene::MeshDesc) -> SceneDesc {
    SceneDesc {
        meshes: vec![panel],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: Mat4::IDENTITY,
            name: "panel".into(),
        }],
        materials: vec![emissive_material("panel", Vec3::ONE, false)],
        camera: Some(common::scenes::camera(0.0, 3.0)),
        ..Default::default()
    }
}

#[test]
fn a_single_light_is_chosen_with_probability_one_and_gives_nothing_where_it_cannot_light() {
    // One light object, alone or with a sun (whose next-event sample is split off): the first
    // choice skips the tree's importance (it would only say whether the point can be lit).
    // Where the one-sided panel can light the point, it is chosen with probability 1 and
    // sampled with the density MIS uses; behind it, or where it is below the point's horizon,
    // its samples must come back empty (no shadow ray, no light), as when the importance said
    // so; the sun keeps its own sample with probability 1.
    let h = 1.0;
    let mut panel = quad_mesh("panel", Vec3::ZERO, Vec3::X, Vec3::Z, 0);
    panel.positions = vec![
        Vec3::new(-0.5, h, -0.5),
        Vec3::new(0.5, h, -0.5),
        Vec3::new(0.5, h, 0.5),
        Vec3::new(-0.5, h, 0.5),
    ];
    for with_sun in [false, true] {
        let mut desc = panel_desc(panel.clone());
        if with_sun {
            desc.lights = vec![PunctualLightDesc {
                name: "sun".into(),
                kind: PunctualKind::Directional,
                color: Vec3::ONE,
                intensity: 2.0,
                direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
                ..Default::default()
            }];
        }
        let scene = Scene::build(desc).expect("scene builds");
        check_single_light(&scene, h, with_sun);
    }
}

fn check_single_light(scene: &Scene, h: f32, with_sun: bool) {
    let lights = &scene.lights;
    assert_eq!(lights.len(), 1 + with_sun as usize);
    let panel = (0..lights.len())
        .find(|&i| matches!(lights.light(i), Light::TrianglePair { .. }))
        .expect("the panel is one light");
    let w = SampledWavelengths::sample_hero(0.3, Default::default());
    let mut rng = Pcg32::new(3, 1, 4);
    let below = ShadingContext {
        p: Vec3::new(0.2, h - 0.7, 0.1),
        n: Some(Vec3::Y),
        time: 0.5,
    };
    assert_eq!(lights.pmf(&below, panel, LightSelection::Tree), 1.0);
    if with_sun {
        let sun = 1 - panel;
        assert_eq!(lights.pmf(&below, sun, LightSelection::Tree), 1.0);
    }
    let (index, p) = lights
        .select(&below, 0.37, LightSelection::Tree)
        .expect("the panel lights the point below it");
    assert_eq!((index, p), (panel, 1.0));
    for _ in 0..200 {
        let samples = random_light_samples(scene, &below, &mut rng, &w, LightSelection::Tree);
        let count = |light: usize| {
            samples
                .iter()
                .flatten()
                .filter(|ls| ls.light == light)
                .count()
        };
        assert_eq!(count(panel), 1, "one sample of the panel from below");
        if with_sun {
            assert_eq!(count(1 - panel), 1, "one sample of the sun, split off");
        } else {
            let u = Vec2::new(rng.next_1d(), rng.next_1d());
            sample_meeting_the_emitter(scene, &below, rng.next_1d(), u, &w)
                .expect("a sample of the panel from below");
        }
    }
    // Behind the panel (it faces down), and below it with the normal facing away from it.
    let behind = ShadingContext {
        p: Vec3::new(0.1, h + 0.5, 0.0),
        n: Some(Vec3::Y),
        time: 0.5,
    };
    let facing_away = ShadingContext {
        n: Some(-Vec3::Y),
        ..below
    };
    for _ in 0..200 {
        let samples = random_light_samples(scene, &behind, &mut rng, &w, LightSelection::Tree);
        assert!(
            samples.iter().flatten().all(|ls| ls.light != panel),
            "a light sample of the panel from behind it"
        );
        // Facing away, the panel's sample (the light does not look at the point's normal) lies
        // below the point's horizon, where the BSDF gives it nothing before any shadow ray.
        let samples = random_light_samples(scene, &facing_away, &mut rng, &w, LightSelection::Tree);
        for ls in samples.iter().flatten().filter(|ls| ls.light == panel) {
            assert!(ls.wi.dot(-Vec3::Y) < 0.0, "towards {:?}", ls.wi);
        }
    }
}
