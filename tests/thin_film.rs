//! Thin-film interference end to end: a soap film (400 nm, IOR 1.33) on an index-matched shell
//! (IOR 1: a single interface that does not refract) reflects a uniform white emitter; the
//! rendered colour must be the CIE integral of the Airy reflectance times the emitter's
//! spectrum, computed here by quadrature independently of the renderer's wavelength sampling.
//! An RGB renderer can only approximate this (Cycles averages the interference over each
//! channel's band, Belcour & Barla 2017); a spectral one gets it exactly.

mod common;

use common::scenes::{camera, emissive_material, material_with, quad_mesh, render_mean};
use glam::{Mat4, Vec3, Vec4};
use prism::bsdf::ThinFilm;
use prism::scene::{GltfMaterialDesc, InstanceDesc, SceneDesc, WorldDesc};
use prism::spectrum::cie::{d65_normalized, integrate_xyz};
use prism::spectrum::rgb::xyz_to_linear_srgb;

fn film_scene(theta: f32, film: ThinFilm) -> SceneDesc {
    // The film's normal tilted by theta from the view axis (+z), the mirror direction of the
    // view, and a one-sided white emitter there (8 away, +-20 degrees), facing the film, out of
    // the way of the light the film transmits.
    let n = Vec3::new(0.0, theta.sin(), theta.cos());
    let r = 2.0 * n.z * n - Vec3::Z;
    let (u, v) = {
        let a = r.cross(Vec3::X).normalize();
        let b = a.cross(r).normalize();
        (a * 3.0, b * 3.0)
    };
    // quad_mesh's front face is along u x v; make it face the film (-r).
    let (u, v) = if u.cross(v).dot(r) > 0.0 {
        (v, u)
    } else {
        (u, v)
    };
    let shell = GltfMaterialDesc {
        name: "film".into(),
        base_color: Vec4::ONE,
        metallic: 0.0,
        roughness: 0.0,
        transmission: 1.0,
        ior: 1.0,
        iridescence: 1.0,
        iridescence_ior: film.ior,
        iridescence_thickness: film.thickness_nm,
        double_sided: true,
        ..Default::default()
    };
    let film_quad = {
        let a = n.cross(Vec3::X).normalize();
        let b = n.cross(a).normalize();
        // Front face along +n (towards the camera).
        let (a, b) = if a.cross(b).dot(n) > 0.0 {
            (a, b)
        } else {
            (b, a)
        };
        quad_mesh("film", Vec3::ZERO, a * 2.0, b * 2.0, 0)
    };
    SceneDesc {
        meshes: vec![film_quad, quad_mesh("light", r * 8.0, u, v, 1)],
        instances: (0..2)
            .map(|mesh| InstanceDesc {
                mesh,
                object_to_world: Mat4::IDENTITY,
                name: format!("i{mesh}"),
            })
            .collect(),
        materials: vec![
            material_with(shell, None),
            emissive_material("white", Vec3::ONE, false),
        ],
        camera: Some(camera(3.0, 0.01)),
        world: WorldDesc {
            color: Vec3::ZERO,
            strength: 0.0,
            texture: None,
        },
        ..Default::default()
    }
}

#[test]
fn soap_film_reflects_the_airy_colour() {
    for (theta_deg, thickness) in [(40.0f32, 400.0f32), (15.0, 250.0), (60.0, 700.0)] {
        let theta = theta_deg.to_radians();
        let film = ThinFilm {
            thickness_nm: thickness,
            ior: 1.33,
        };
        let (mean, _) = render_mean(film_scene(theta, film), 8, 256, 4, 3);
        let xyz = integrate_xyz(
            |l| film.reflectance(theta.cos(), 1.0, l) * d65_normalized(l),
            4,
        );
        let want = xyz_to_linear_srgb(xyz);
        println!("film {thickness} nm at {theta_deg} deg: rendered {mean}, Airy {want}");
        for c in 0..3 {
            assert!(
                (mean[c] - want[c]).abs() < 0.01 * want.max_element() + 2e-4,
                "{thickness} nm at {theta_deg} deg: rendered {mean} vs Airy {want}"
            );
        }
        // The colour is far from grey: the test would notice a wavelength-blind Fresnel.
        assert!(want.max_element() > 1.3 * want.min_element(), "{want}");
    }
}
