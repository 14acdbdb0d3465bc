//! Renders with closed-form answers: a Lambertian plane under each punctual light type, and
//! Beer–Lambert absorption through an index-matched (eta = 1) absorbing sphere.

mod common;

use common::scenes::{camera, diffuse_material, emissive_material, furnace_scene, material_with};
use glam::{Mat4, Vec3};
use prism::scene::{
    DielectricDesc, GltfMaterialDesc, InstanceDesc, IorDesc, MaterialOverride, MeshDesc,
    PunctualKind, PunctualLightDesc, SceneDesc,
};

const ALBEDO: f32 = 0.5;

/// A 20 x 20 horizontal quad at y = 0 facing +y, seen from (0, 3, 0) looking straight down.
fn plane_scene(light: PunctualLightDesc) -> SceneDesc {
    let p = [
        Vec3::new(-10.0, 0.0, -10.0),
        Vec3::new(10.0, 0.0, -10.0),
        Vec3::new(10.0, 0.0, 10.0),
        Vec3::new(-10.0, 0.0, 10.0),
    ];
    let mut cam = camera(0.0, 0.05);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    SceneDesc {
        meshes: vec![MeshDesc {
            name: "plane".into(),
            positions: p.to_vec(),
            normals: Some(vec![Vec3::Y; 4]),
            uvs: None,
            tangents: None,
            indices: vec![0, 2, 1, 0, 3, 2],
            material: Some(0),
            ..Default::default()
        }],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: Mat4::IDENTITY,
            name: "plane".into(),
        }],
        materials: vec![diffuse_material("grey", Vec3::splat(ALBEDO))],
        lights: vec![light],
        camera: Some(cam),
        ..Default::default()
    }
}

fn mean_rgb(desc: SceneDesc, spp: u32) -> Vec3 {
    common::scenes::render_mean(desc, 8, spp, 4, 3).0
}

fn assert_close(got: Vec3, want: f32, tol: f32, what: &str) {
    for c in got.to_array() {
        assert!(
            (c - want).abs() <= tol * want,
            "{what}: got {got}, want {want} (+-{:.1}%)",
            tol * 100.0
        );
    }
}

fn light(kind: PunctualKind, intensity: f32, position: Vec3, direction: Vec3) -> PunctualLightDesc {
    PunctualLightDesc {
        name: "l".into(),
        kind,
        color: Vec3::ONE,
        intensity,
        position,
        direction,
        ..Default::default()
    }
}

/// A point light of radius `radius` at height `h` above the plane.
fn round_point(i: f32, h: f32, radius: f32, soft_falloff: bool) -> PunctualLightDesc {
    PunctualLightDesc {
        radius,
        soft_falloff,
        ..light(PunctualKind::Point, i, Vec3::new(0.0, h, 0.0), -Vec3::Y)
    }
}

/// Blender's point light with a radius r and Soft Falloff: a disc of radiance I / (pi r^2)
/// facing the shading point, whose on-axis irradiance is pi L r^2 / (r^2 + h^2) = I / (r^2 +
/// h^2). Lit by light sampling and by BSDF rays hitting the disc, combined with MIS.
#[test]
fn soft_point_light_is_a_facing_disc() {
    let (i, h, r) = (8.0, 2.0, 1.0);
    let got = mean_rgb(plane_scene(round_point(i, h, r, true)), 256);
    let want = ALBEDO / std::f32::consts::PI * i / (r * r + h * h);
    assert_close(got, want, 0.02, "soft point light");
}

/// Without Soft Falloff: a sphere of radiance I / (pi r^2). Outside it, the irradiance of a
/// sphere wholly above the horizon is pi L sin^2(alpha) = I / h^2, the point light's; inside
/// it (the plane cuts the sphere), every direction of the upper hemisphere sees L: E = I / r^2.
#[test]
fn sphere_point_light_outside_and_inside() {
    let (i, r) = (8.0, 1.0);
    let outside = mean_rgb(plane_scene(round_point(i, 2.0, r, false)), 256);
    assert_close(
        outside,
        ALBEDO / std::f32::consts::PI * i / 4.0,
        0.02,
        "sphere, outside",
    );
    let inside = mean_rgb(plane_scene(round_point(i, 0.5, r, false)), 256);
    assert_close(
        inside,
        ALBEDO / std::f32::consts::PI * i / (r * r),
        0.02,
        "sphere, inside",
    );
}

/// Irradiance at the origin, on a surface facing +y, from a polygon of radiance `l` (Lambert's
/// formula: E = L / 2 sum_i theta_i (n . gamma_i), gamma_i the unit normal of the plane through
/// the origin and edge i, theta_i the angle the edge subtends).
fn polygon_irradiance(l: f32, corners: &[Vec3]) -> f32 {
    let mut e = 0.0f64;
    for (i, a) in corners.iter().enumerate() {
        let b = corners[(i + 1) % corners.len()];
        let (a, b) = (a.as_dvec3().normalize(), b.as_dvec3().normalize());
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        e += theta * a.cross(b).normalize().y;
    }
    (0.5 * l as f64 * e.abs()) as f32
}

/// A disc area light (Blender's disc: a fan of triangles, one light, `Light::FlatEmitter`,
/// sampled over its area) of radiance `l` and radius `r` at height `h` facing down: the
/// plane's exitance under it is the polygon's irradiance (Lambert's formula), far from the
/// disc for its size and close under it, where area sampling has the most variance.
#[test]
fn disc_area_light_gives_its_polygons_irradiance() {
    for (h, r) in [(2.0, 0.5), (0.4, 1.0)] {
        let l = 3.0;
        let segments = 48;
        let mut positions = vec![Vec3::new(0.0, h, 0.0)];
        for k in 0..segments {
            let a = std::f32::consts::TAU * k as f32 / segments as f32;
            positions.push(Vec3::new(r * a.cos(), h, r * a.sin()));
        }
        // (centre, p_k, p_k+1) faces down (-y), towards the plane.
        let indices = (0..segments)
            .flat_map(|k| [0, k + 1, (k + 1) % segments + 1])
            .collect();
        let mut desc = plane_scene(light(PunctualKind::Point, 0.0, Vec3::Y, -Vec3::Y));
        desc.lights.clear();
        desc.meshes.push(MeshDesc {
            name: "disc".into(),
            positions: positions.clone(),
            indices,
            material: Some(1),
            ..Default::default()
        });
        desc.instances.push(InstanceDesc {
            mesh: 1,
            object_to_world: Mat4::IDENTITY,
            name: "disc".into(),
        });
        desc.materials
            .push(emissive_material("disc", Vec3::splat(l), false));
        // As the add-on writes an area light: a mesh that is a light only.
        desc.instance_visibility = vec![
            Default::default(),
            prism::scene::InstanceVisibility {
                casts_shadows: false,
                camera_visible: false,
                light_only: true,
                ..Default::default()
            },
        ];
        let cam = desc.camera.as_mut().unwrap();
        cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 0.5 * h, 0.0))
            * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        let scene = prism::scene::Scene::build(desc.clone()).expect("scene builds");
        let flat = (0..scene.lights.len())
            .filter(|&i| {
                matches!(
                    scene.lights.light(i),
                    prism::lights::Light::FlatEmitter { .. }
                )
            })
            .count();
        assert_eq!((scene.lights.len(), flat), (1, 1), "the disc is one light");
        let got = mean_rgb(desc, 256);
        let want = ALBEDO / std::f32::consts::PI * polygon_irradiance(l, &positions[1..]);
        assert_close(got, want, 0.02, &format!("disc light, h {h}, r {r}"));
    }
}

/// A spot light with a radius has its disc's irradiance inside the cone and none outside.
#[test]
fn soft_spot_light_inside_and_outside_cone() {
    let (i, h, r) = (8.0, 2.0, 0.5);
    let spot = |direction| PunctualLightDesc {
        radius: r,
        soft_falloff: true,
        ..light(
            PunctualKind::Spot {
                inner_cone: 0.5,
                outer_cone: 0.6,
            },
            i,
            Vec3::new(0.0, h, 0.0),
            direction,
        )
    };
    let want = ALBEDO / std::f32::consts::PI * i / (r * r + h * h);
    assert_close(
        mean_rgb(plane_scene(spot(-Vec3::Y)), 256),
        want,
        0.02,
        "soft spot",
    );
    assert_eq!(mean_rgb(plane_scene(spot(Vec3::X)), 16), Vec3::ZERO);
}

/// Camera rays see a light's disc only with Camera visibility on (off by default, as in
/// Blender); a mirror always reflects it. The light hangs between the camera (looking down from
/// y = 3) and the plane.
#[test]
fn round_light_camera_visibility_and_mirror_reflection() {
    let (i, r) = (8.0, 0.5);
    let radiance = i / (std::f32::consts::PI * r * r);
    let seen = |visible_camera: bool, mirror: bool| {
        let mut desc = plane_scene(PunctualLightDesc {
            visible_camera,
            ..round_point(i, 1.5, r, true)
        });
        if mirror {
            desc.materials[0].gltf.metallic = 1.0;
            desc.materials[0].gltf.roughness = 0.0;
            desc.materials[0].gltf.base_color = Vec3::ONE.extend(1.0);
        } else {
            desc.materials[0].gltf.base_color = Vec3::ZERO.extend(1.0);
        }
        mean_rgb(desc, 16)
    };
    // A black plane: what the camera sees is the light itself, or nothing.
    assert_close(
        seen(true, false),
        radiance,
        0.01,
        "light seen by the camera",
    );
    assert_eq!(seen(false, false), Vec3::ZERO);
    // A white mirror: the light's reflection (the camera ray passes the hidden light first).
    assert_close(seen(false, true), radiance, 0.01, "light seen in a mirror");
}

#[test]
fn point_light_inverse_square_law() {
    // Radiance of a Lambertian point at distance h straight below: rho/pi * I / h^2.
    let (i, h) = (8.0, 2.0);
    let got = mean_rgb(
        plane_scene(light(
            PunctualKind::Point,
            i,
            Vec3::new(0.0, h, 0.0),
            -Vec3::Y,
        )),
        256,
    );
    assert_close(
        got,
        ALBEDO / std::f32::consts::PI * i / (h * h),
        0.02,
        "point light",
    );
}

#[test]
fn spot_light_inside_and_outside_cone() {
    let (i, h) = (8.0, 2.0);
    let inside = light(
        PunctualKind::Spot {
            inner_cone: 0.3,
            outer_cone: 0.4,
        },
        i,
        Vec3::new(0.0, h, 0.0),
        -Vec3::Y,
    );
    assert_close(
        mean_rgb(plane_scene(inside), 256),
        ALBEDO / std::f32::consts::PI * i / (h * h),
        0.02,
        "spot centre",
    );
    // Aimed away (horizontal): the spot below the light gets nothing.
    let away = light(
        PunctualKind::Spot {
            inner_cone: 0.3,
            outer_cone: 0.4,
        },
        i,
        Vec3::new(0.0, h, 0.0),
        Vec3::X,
    );
    assert_eq!(mean_rgb(plane_scene(away), 16), Vec3::ZERO);
}

#[test]
fn directional_light_cosine_law() {
    // Irradiance E at 60 degrees from the normal: radiance rho/pi * E cos(60).
    let e = 3.0;
    let dir = Vec3::new(60f32.to_radians().sin(), -60f32.to_radians().cos(), 0.0);
    let got = mean_rgb(
        plane_scene(light(PunctualKind::Directional, e, Vec3::ZERO, dir)),
        256,
    );
    assert_close(
        got,
        ALBEDO / std::f32::consts::PI * e * 0.5,
        0.02,
        "directional light",
    );
}

#[test]
fn beer_lambert_through_index_matched_sphere() {
    // eta = 1: rays pass straight through, so the centre pixel sees the white world through
    // a chord of length 2 (the diameter): exp(-2 sigma) with sigma = -ln(0.5) / 1.
    let glass = material_with(
        GltfMaterialDesc {
            name: "absorber".into(),
            attenuation_color: Vec3::splat(0.5),
            attenuation_distance: 1.0,
            ..Default::default()
        },
        Some(MaterialOverride::Dielectric(DielectricDesc {
            ior: IorDesc::Constant(1.0),
            roughness: 0.0,
        })),
    );
    let mut desc = furnace_scene(glass, Vec3::ONE);
    desc.camera = Some(camera(5.0, 0.02)); // a narrow view of the sphere's centre
    let got = mean_rgb(desc, 64);
    assert_close(got, 0.25, 0.02, "absorption");
}
