//! Wavelength-dependent IOR models (`prism::spectrum::dispersion`) against published data, and
//! their two entry points: the material sidecar and glTF's KHR_materials_dispersion.
//!
//! Expected values are copied from the cited publications, never computed with our formulas.
//! n_F, n_d, n_C are at the Fraunhofer F (486.13 nm), d (587.56 nm) and C (656.27 nm) lines.

#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use gltf_builder::*;
use prism::scene::materials_json::parse_materials_json;
use prism::scene::{load_scene, MaterialOverride};
use prism::spectrum::dispersion::{IorModel, GLASS_PRESETS, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};
use serde_json::json;

/// Published data of one preset.
struct Published {
    preset: &'static str,
    n_d: f64,
    /// Abbe number V_d as published (2 decimals), which pins n_F - n_C.
    v_d: f64,
    /// (n_F, n_C) where the source prints them.
    n_f_c: Option<(f64, f64)>,
    /// Where the numbers come from, for failure messages.
    source: &'static str,
}

const PUBLISHED: &[Published] = &[
    // SCHOTT N-BK7 data sheet: nd = 1.51680, nF = 1.52238, nC = 1.51432, vd = 64.17.
    // nd and vd checked against refractiveindex.info (SCHOTT data sheet record: n(0.5876 µm) =
    // 1.5168, Vd = 64.17); nF and nC are quoted from the data sheet and were not re-checked
    // online in this session (they agree with nd and vd to the rounding of 5 decimals).
    Published {
        preset: "BK7",
        n_d: 1.51680,
        v_d: 64.17,
        n_f_c: Some((1.52238, 1.51432)),
        source: "SCHOTT N-BK7 data sheet",
    },
    // Malitson 1965 (JOSA 55, 1205), measured indices of fused silica at 20 °C: 1.46313 (F),
    // 1.45846 (d), 1.45637 (C). n(0.5876 µm) = 1.45846 checked on refractiveindex.info; the F
    // and C values are quoted from the paper's table, not re-checked online in this session.
    // Vd = (1.45846 - 1) / (1.46313 - 1.45637) = 67.8.
    Published {
        preset: "fused_silica",
        n_d: 1.45846,
        v_d: 67.82,
        n_f_c: Some((1.46313, 1.45637)),
        source: "Malitson 1965",
    },
    // SCHOTT F2 data sheet: nd = 1.62004, nF = 1.63208, nC = 1.61503, vd = 36.37 (quoted from
    // the data sheet; not re-checked online in this session).
    Published {
        preset: "F2",
        n_d: 1.62004,
        v_d: 36.37,
        n_f_c: Some((1.63208, 1.61503)),
        source: "SCHOTT F2 data sheet",
    },
    // SCHOTT SF11 data sheet: nd = 1.78472, vd = 25.68 (glass code 785257). Its nF and nC could
    // not be verified in this session, so only nd and vd are checked (vd pins nF - nC to
    // ~2e-5).
    Published {
        preset: "SF11",
        n_d: 1.78472,
        v_d: 25.68,
        n_f_c: None,
        source: "SCHOTT SF11 data sheet",
    },
    // refractiveindex.info, diamond (Peter 1923 / Handbook of Optics Sellmeier form):
    // n(0.5876 µm) = 2.41748, Vd = 55.30. Measured nF and nC of Peter's paper not verified.
    Published {
        preset: "diamond",
        n_d: 2.41748,
        v_d: 55.30,
        n_f_c: None,
        source: "refractiveindex.info, diamond (Peter 1923)",
    },
    // refractiveindex.info, water, Daimon & Masumura 2007 at 20.0 °C (absolute index, i.e.
    // relative to vacuum; the familiar n_D = 1.33299 is relative to air): n(0.5876 µm) =
    // 1.3334 (4 decimals), Vd = 55.76.
    Published {
        preset: "water",
        n_d: 1.3334,
        v_d: 55.76,
        n_f_c: None,
        source: "refractiveindex.info, water (Daimon & Masumura 2007, 20 °C)",
    },
];

fn n(m: &IorModel, nm: f32) -> f64 {
    f64::from(m.eval(nm))
}

#[test]
fn presets_reproduce_published_indices() {
    assert_eq!(
        PUBLISHED.iter().map(|p| p.preset).collect::<Vec<_>>(),
        GLASS_PRESETS,
        "every preset has published data here"
    );
    for p in PUBLISHED {
        let m = IorModel::preset(p.preset).unwrap();
        let (nf, nd, nc) = (n(&m, LAMBDA_F_NM), n(&m, LAMBDA_D_NM), n(&m, LAMBDA_C_NM));
        println!(
            "{:13} n_F {nf:.6} n_d {nd:.6} n_C {nc:.6} V_d {:.3}",
            p.preset,
            (nd - 1.0) / (nf - nc)
        );
        assert!(
            (nd - p.n_d).abs() < 1e-4,
            "{}: n_d {nd} vs {} ({})",
            p.preset,
            p.n_d,
            p.source
        );
        assert!((f64::from(m.n_d()) - nd).abs() < 1e-7);
        let v = f64::from(m.abbe_number().unwrap());
        // V_d is published with 2 decimals; 0.02 also covers the n_d rounding of water.
        assert!(
            (v - p.v_d).abs() < 0.02,
            "{}: V_d {v} vs {} ({})",
            p.preset,
            p.v_d,
            p.source
        );
        if let Some((pf, pc)) = p.n_f_c {
            assert!(
                (nf - pf).abs() < 1e-4 && (nc - pc).abs() < 1e-4,
                "{}: n_F {nf} n_C {nc} vs {pf} {pc} ({})",
                p.preset,
                p.source
            );
            // The quoted F and C values are consistent with the published V_d (5-decimal
            // rounding of n_F - n_C allows about 0.1% of V_d).
            let v_pub = (p.n_d - 1.0) / (pf - pc);
            assert!(
                (v_pub - p.v_d).abs() < 2e-3 * p.v_d,
                "{}: published data disagree",
                p.preset
            );
        }
    }
}

#[test]
fn textbook_cauchy_bk7() {
    // The common textbook two-term Cauchy fit of BK7: A = 1.5046, B = 0.00420 µm²
    // (e.g. Hecht, "Optics"; Wikipedia "Cauchy's equation"). Published n_d = 1.51680 (SCHOTT).
    let m = IorModel::cauchy(1.5046, 0.00420, 0.0).unwrap();
    let nd = n(&m, LAMBDA_D_NM);
    assert!((nd - 1.51680).abs() < 1e-4, "n_d {nd}");
}

#[test]
fn abbe_form() {
    // By construction: n(λ_d) = n_d and (n_d - 1)/(n_F - n_C) = V_d.
    for (nd, vd) in [
        (1.5168f32, 64.17f32),
        (1.78472, 25.68),
        (2.4175, 55.3),
        (1.0, 30.0),
    ] {
        let m = IorModel::from_abbe(nd, vd).unwrap();
        assert_eq!(m.n_d(), nd);
        assert!((m.eval(LAMBDA_D_NM) - nd).abs() <= 1e-6, "{nd}");
        if nd > 1.0 {
            let v = m.abbe_number().unwrap();
            assert!((v - vd).abs() < 1e-3, "V_d {v} vs {vd}");
        }
    }

    // BK7 catalogue numbers (n_d 1.5168, V_d 64.17) against the SCHOTT data sheet's
    // n_F = 1.52238, n_C = 1.51432: the two-term Cauchy is within 6e-5.
    let bk7 = IorModel::from_abbe(1.5168, 64.17).unwrap();
    let (nf, nc) = (n(&bk7, LAMBDA_F_NM), n(&bk7, LAMBDA_C_NM));
    println!(
        "Abbe BK7: n_F {nf:.6} (err {:.1e}), n_C {nc:.6} (err {:.1e})",
        nf - 1.52238,
        nc - 1.51432
    );
    assert!((nf - 1.52238).abs() < 1e-4, "n_F {nf}");
    assert!((nc - 1.51432).abs() < 1e-4, "n_C {nc}");

    // SF11 (n_d 1.78472, V_d 25.68): a two-term Cauchy cannot follow this dense flint's
    // curvature. Against SCHOTT's SF11 Sellmeier curve (our preset; the data sheet's own n_F and
    // n_C could not be verified) the Abbe form is about 4.3e-4 low at both F and C, i.e. it
    // EXCEEDS the 1e-4 target. The bound below documents that error; it is not a loosened
    // tolerance for the presets (those are held to 1e-4 above).
    let sf11 = IorModel::from_abbe(1.78472, 25.68).unwrap();
    let schott = IorModel::preset("SF11").unwrap();
    let ef = n(&sf11, LAMBDA_F_NM) - n(&schott, LAMBDA_F_NM);
    let ec = n(&sf11, LAMBDA_C_NM) - n(&schott, LAMBDA_C_NM);
    println!("Abbe SF11 vs SCHOTT Sellmeier: n_F err {ef:.1e}, n_C err {ec:.1e}");
    assert!(ef.abs() > 1e-4 && ef.abs() < 6e-4, "{ef}");
    assert!(ec.abs() > 1e-4 && ec.abs() < 6e-4, "{ec}");
}

#[test]
fn models_are_monotone_and_in_range_over_the_visible() {
    // Normal dispersion: n falls with wavelength across 360–830 nm for every preset.
    for p in GLASS_PRESETS {
        let m = IorModel::preset(p).unwrap();
        let mut prev = f32::INFINITY;
        for l in (360..=830).step_by(10) {
            let x = m.eval(l as f32);
            assert!(x >= 1.0 && x < prev, "{p}: n({l}) = {x}");
            prev = x;
        }
    }
}

#[test]
fn sidecar_forms_reach_the_model() {
    let names = vec!["Glass".to_string()];
    let parse = |body: &str| {
        let text = format!(r#"{{"version":1,"materials":{{"Glass":{{"dielectric":{body}}}}}}}"#);
        let f = parse_materials_json(&text, "m.json", Some(&names)).unwrap();
        let MaterialOverride::Dielectric(d) = &f.materials[0].1 else {
            panic!("{body}")
        };
        d.ior
    };
    let sf11 = parse(r#"{"preset":"SF11"}"#);
    assert!(sf11.is_dispersive());
    assert!((sf11.n_d() - 1.78472).abs() < 1e-4);
    let abbe = parse(r#"{"abbe":{"ior":1.5168,"abbe":64.17}}"#);
    assert!((abbe.abbe_number().unwrap() - 64.17).abs() < 1e-3);
    assert!(!parse(r#"{"ior":1.5}"#).is_dispersive());
}

fn glass_scene(name: &str, ior: Option<f32>, dispersion: serde_json::Value) -> std::path::PathBuf {
    let dir = test_dir(name);
    let mut b = GltfBuilder::basic();
    for e in [
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_dispersion",
    ] {
        b.use_ext(e);
    }
    let mut ext = json!({
        "KHR_materials_transmission": { "transmissionFactor": 1.0 },
        "KHR_materials_dispersion": dispersion,
    });
    if let Some(i) = ior {
        ext["KHR_materials_ior"] = json!({ "ior": i });
    }
    let glass = b.material(json!({
        "name": "Glass",
        "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 },
        "extensions": ext,
    }));
    let q = b.quad_mesh("G", Some(glass));
    b.root(json!({ "name": "G", "mesh": q }));
    b.write_gltf(&dir.join("glass.gltf"))
}

/// The IOR model the loader gives the material named "Glass" of a scene.
fn glass_ior(path: &std::path::Path) -> IorModel {
    let s = load_scene(path, None, None).unwrap();
    let glass = s.materials.iter().find(|m| m.gltf.name == "Glass").unwrap();
    glass.gltf.ior_model()
}

#[test]
fn gltf_khr_materials_dispersion() {
    // dispersion = 20 / V_d: 0.5 -> V_d = 40, n_d from KHR_materials_ior.
    let path = glass_scene("dispersion_gltf", Some(1.6), json!({ "dispersion": 0.5 }));
    let s = load_scene(&path, None, None).unwrap();
    let g = s.materials.iter().find(|m| m.gltf.name == "Glass").unwrap();
    assert_eq!(g.gltf.dispersion, 0.5);
    let m = g.gltf.ior_model();
    assert!(m.is_dispersive());
    assert_eq!(m.n_d(), 1.6);
    assert!((m.abbe_number().unwrap() - 40.0).abs() < 1e-3, "{m:?}");
    assert!(
        !s.warnings.iter().any(|w| w.contains("dispersion")),
        "{:?}",
        s.warnings
    );

    // Without KHR_materials_ior, n_d is the glTF default 1.5.
    let path = glass_scene(
        "dispersion_gltf_default_ior",
        None,
        json!({ "dispersion": 1.0 }),
    );
    let m = glass_ior(&path);
    assert_eq!(m.n_d(), 1.5);
    assert!((m.abbe_number().unwrap() - 20.0).abs() < 1e-3);

    // dispersion 0 (or absent) is a constant IOR.
    let path = glass_scene(
        "dispersion_gltf_zero",
        Some(1.4),
        json!({ "dispersion": 0.0 }),
    );
    let m = glass_ior(&path);
    assert_eq!(m, IorModel::Constant(1.4));
}

#[test]
fn gltf_bad_dispersion_is_a_clear_error() {
    for (name, d, want) in [
        (
            "dispersion_gltf_negative",
            json!({ "dispersion": -0.5 }),
            "KHR_materials_dispersion.dispersion must be a non-negative number, got -0.5",
        ),
        (
            "dispersion_gltf_string",
            json!({ "dispersion": "lots" }),
            "KHR_materials_dispersion.dispersion must be a number, got \"lots\"",
        ),
    ] {
        let path = glass_scene(name, Some(1.5), d);
        let e = match load_scene(&path, None, None) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{name}: loaded"),
        };
        assert!(e.contains(want), "{name}: {e}");
        assert!(e.contains("material 'Glass'"), "{name}: {e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

/// A valid but extreme pair (the extension allows any dispersion >= 0) that the Abbe form
/// cannot follow over 360-830 nm renders without dispersion, with a warning.
#[test]
fn gltf_dispersion_beyond_the_abbe_form_is_a_warning() {
    // V_d = 20 / 40 = 0.5: n drops below 1 in the red.
    let path = glass_scene(
        "dispersion_gltf_huge",
        Some(1.5),
        json!({ "dispersion": 40.0 }),
    );
    let scene = load_scene(&path, None, None).expect("loads");
    let w = scene.warnings.join("\n");
    assert!(
        w.contains("material 'Glass': KHR_materials_dispersion ignored")
            && w.contains("the index of refraction must be >= 1 over 360–830 nm"),
        "{w}"
    );
    assert_eq!(glass_ior(&path), IorModel::Constant(1.5));
}

#[test]
fn readme_sidecar_example_parses() {
    // The README's material JSON example shows every IOR form; keep it valid.
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let section = &readme[readme.find("## Material JSON sidecar").unwrap()..];
    let start = section.find("```json\n").unwrap() + "```json\n".len();
    let block = &section[start..start + section[start..].find("```").unwrap()];
    let f = parse_materials_json(block, "README.md", None).unwrap();
    let get = |n: &str| &f.materials.iter().find(|(m, _)| m == n).unwrap().1;
    let MaterialOverride::Dielectric(quartz) = get("Quartz") else {
        panic!()
    };
    // Malitson's coefficients with the C_i rounded to 9 digits: the preset within 1e-7.
    let silica = IorModel::preset("fused_silica").unwrap();
    for l in [LAMBDA_F_NM, LAMBDA_D_NM, LAMBDA_C_NM] {
        assert!((quartz.ior.eval(l) - silica.eval(l)).abs() < 1e-6);
    }
    let MaterialOverride::Subsurface(jade) = get("Jade") else {
        panic!()
    };
    assert_eq!(jade.eta, 1.66);
    assert!(jade.ior.unwrap().is_dispersive());
    assert_eq!(f.render.wavelength_pdf.as_deref(), Some("rgb"));
}
