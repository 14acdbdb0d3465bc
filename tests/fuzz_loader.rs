//! A bounded mutation fuzzer for the scene loader (glTF / GLB) and the material JSON sidecar
//! (issue 16): seeds from the repository's corpora are mutated byte-wise and JSON-aware, loaded
//! in-process, and, when they load, built and rendered at 4 x 3 pixels. Every outcome must be
//! `Ok` or a one-line `PrismError`; a panic, a non-finite pixel or a case running longer than
//! [`CASE_TIMEOUT`] fails the test and leaves the input in `target/tmp/fuzz_loader/failures/`.
//!
//! CI runs it for `PRISM_FUZZ_SECONDS` (default 20) seconds; by hand, longer:
//! `PRISM_FUZZ_SECONDS=600 cargo test --release --test fuzz_loader -- --nocapture`
//! (`PRISM_FUZZ_SEED` picks another deterministic sequence).

use prism::render::{render_quiet, RenderSettings};
use prism::sampler::Pcg32;
use prism::scene::materials_json::load_materials_file;
use prism::scene::{load_scene, Scene};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const CASE_TIMEOUT: Duration = Duration::from_secs(20);

/// The renderer's own PCG32 stream, with a bounded draw.
struct Rng(Pcg32);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        (self.0.next_u32() as usize) % n.max(1)
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Gltf,
    Glb,
    Sidecar,
}

struct Seed {
    kind: Kind,
    bytes: Vec<u8>,
    /// A sidecar that goes with a glTF seed (`<stem>.materials.json`).
    sidecar: Option<Vec<u8>>,
}

fn seeds() -> Vec<Seed> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    let mut add_dir = |dir: PathBuf| {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            let bytes = std::fs::read(&p).unwrap();
            if name.ends_with(".materials.json") {
                out.push(Seed {
                    kind: Kind::Sidecar,
                    bytes,
                    sidecar: None,
                });
            } else if name.ends_with(".gltf") || name.ends_with(".glb") {
                let sidecar = std::fs::read(p.with_extension("materials.json")).ok();
                let kind = if name.ends_with(".glb") {
                    Kind::Glb
                } else {
                    Kind::Gltf
                };
                out.push(Seed {
                    kind,
                    bytes,
                    sidecar,
                });
            }
        }
    };
    for d in [
        "tests/data/malformed",
        "tests/data/lenient",
        "tests/data/edge",
    ] {
        add_dir(root.join(d));
    }
    for d in ["scenes/cornell", "scenes/prism", "scenes/sss_presets"] {
        add_dir(root.join(d));
    }
    // The binary container around each small valid scene (JSON chunk only; its buffers stay
    // data URIs), so mutations reach the GLB header and chunk table with a loadable payload.
    let glbs: Vec<Seed> = out
        .iter()
        .filter(|s| s.kind == Kind::Gltf && s.bytes.len() < 64 * 1024)
        .map(|s| Seed {
            kind: Kind::Glb,
            bytes: glb(&s.bytes),
            sidecar: s.sidecar.clone(),
        })
        .collect();
    out.extend(glbs);
    // Sidecar features the corpora lack: a graph, a volume, the world and render settings.
    out.push(Seed {
        kind: Kind::Sidecar,
        bytes: serde_json::json!({"version": 1,
            "materials": {
                "White": {"graph": {"version": 1,
                    "nodes": {
                        "Checker": {"type": "checker_texture",
                            "inputs": {"scale": 12.0, "color1": [0.8, 0.8, 0.8], "color2": [0.1, 0.1, 0.1]}},
                        "Noise": {"type": "noise_texture", "inputs": {"scale": 3.0, "detail": 4.0}},
                        "Mix": {"type": "mix_color", "blend_type": "MULTIPLY",
                            "inputs": {"factor": {"node": "Noise", "output": "fac"},
                                "a": {"node": "Checker", "output": "color"}, "b": [1.0, 0.5, 0.2]}}},
                    "inputs": {"base_color": {"node": "Mix", "output": "result"}, "roughness": 0.4}}},
                "Fog": {"volume": {"sigma_s": [0.5, 0.5, 0.5], "sigma_a": [0.1, 0.2, 0.3], "g": 0.3,
                    "emission": [0, 0, 1]}, "surface": "none"},
                "Skin": {"subsurface": {"preset": "Skin1", "scale": 1000.0}}},
            "world": {"color": [0.2, 0.3, 0.4], "strength": 1.5},
            "render": {"width": 32, "height": 24, "spp": 4}})
        .to_string()
        .into_bytes(),
        sidecar: None,
    });
    out
}

/// A binary glTF holding `json` as its only chunk (glTF 2.0 spec 4.4).
fn glb(json: &[u8]) -> Vec<u8> {
    let mut chunk = json.to_vec();
    while !chunk.len().is_multiple_of(4) {
        chunk.push(b' ');
    }
    let total = 12 + 8 + chunk.len() as u32;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&chunk);
    out
}

/// Values that break assumptions: signs, limits of the integer types, huge and tiny floats,
/// strings of the enumerations, empty containers.
fn interesting(rng: &mut Rng) -> Value {
    let pick: &[&str] = &[
        "0",
        "-1",
        "1",
        "2",
        "3",
        "4",
        "255",
        "256",
        "65535",
        "65536",
        "4294967295",
        "4294967296",
        "9007199254740993",
        "-2147483648",
        "1e38",
        "-1e38",
        "3.5e38",
        "1e-45",
        "0.5",
        "-0.0",
        "1e300",
        "null",
        "true",
        "\"\"",
        "\"VEC3\"",
        "\"SCALAR\"",
        "\"MAT4\"",
        "\"data:,\"",
        "\"data:application/octet-stream;base64,AAAA\"",
        "\"point\"",
        "\"spot\"",
        "{}",
        "[]",
        "[0]",
        "[1e38, 1e38, 1e38]",
        "[0, 0, 0, 0]",
        "\"BLEND\"",
        "5126",
        "5123",
        "5121",
        "5125",
        "5120",
        "34962",
        "4",
        "6",
        "7",
    ];
    serde_json::from_str(pick[rng.below(pick.len())]).unwrap()
}

/// All JSON pointers of a document's values, for picking a mutation site.
fn pointers(v: &Value, here: String, out: &mut Vec<String>) {
    out.push(here.clone());
    match v {
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{here}/{i}"), out);
            }
        }
        Value::Object(o) => {
            for (k, x) in o {
                pointers(
                    x,
                    format!("{here}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        _ => {}
    }
}

fn mutate_json(v: &mut Value, rng: &mut Rng) {
    let mut ps = Vec::new();
    pointers(v, String::new(), &mut ps);
    let p = ps[rng.below(ps.len())].clone();
    let op = rng.below(6);
    let Some(target) = v.pointer_mut(&p) else {
        return;
    };
    match op {
        0 | 1 => *target = interesting(rng),
        2 => {
            // Delete a key or an element.
            if let Value::Object(o) = target {
                if !o.is_empty() {
                    let k = o.keys().nth(rng.below(o.len())).unwrap().clone();
                    o.remove(&k);
                }
            } else if let Value::Array(a) = target {
                if !a.is_empty() {
                    a.remove(rng.below(a.len()));
                }
            }
        }
        3 => {
            // Duplicate an element, or grow an array a lot.
            if let Value::Array(a) = target {
                if !a.is_empty() {
                    let x = a[rng.below(a.len())].clone();
                    let n = if rng.below(8) == 0 { 64 } else { 1 };
                    for _ in 0..n {
                        a.push(x.clone());
                    }
                }
            }
        }
        4 => {
            // Nudge a number.
            if let Some(x) = target.as_f64() {
                let d = [-1.0, 1.0, 4.0, -4.0, 0.5][rng.below(5)];
                if let Some(n) = serde_json::Number::from_f64(x + d) {
                    *target = Value::Number(n);
                }
            }
        }
        _ => {
            // Move another value of the document here.
            let q = ps[rng.below(ps.len())].clone();
            if let Some(x) = v.pointer(&q).cloned() {
                if let Some(t) = v.pointer_mut(&p) {
                    *t = x;
                }
            }
        }
    }
}

fn mutate_bytes(b: &mut Vec<u8>, rng: &mut Rng) {
    if b.is_empty() {
        b.push(b'{');
        return;
    }
    let i = rng.below(b.len());
    match rng.below(5) {
        0 => b[i] ^= 1 << rng.below(8),
        1 => b[i] = [0u8, 0xff, b'"', b'{', b'[', b'-', b'9', b'e', b'.'][rng.below(9)],
        2 => {
            let n = rng.below(16).min(b.len() - i);
            b.drain(i..i + n);
        }
        3 => {
            let n = rng.below(16).min(b.len() - i);
            let span: Vec<u8> = b[i..i + n].to_vec();
            let j = rng.below(b.len());
            b.splice(j..j, span);
        }
        _ => {
            // A little-endian u32 field of a GLB header or chunk.
            let j = (rng.below(b.len().min(64)) / 4) * 4;
            let v = [0u32, 1, 0x7fff_ffff, 0xffff_ffff, 20, 12][rng.below(6)].to_le_bytes();
            for (k, x) in v.iter().enumerate() {
                if let Some(y) = b.get_mut(j + k) {
                    *y = *x;
                }
            }
        }
    }
}

fn mutate(seed: &Seed, rng: &mut Rng) -> (Vec<u8>, Option<Vec<u8>>) {
    let mut bytes = seed.bytes.clone();
    let mut sidecar = seed.sidecar.clone();
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        // Mutate the sidecar of a glTF seed now and then.
        let target = match (&mut sidecar, rng.below(4)) {
            (Some(s), 0) => s,
            _ => &mut bytes,
        };
        let parsed = if rng.below(4) != 0 {
            serde_json::from_slice::<Value>(target).ok()
        } else {
            None
        };
        match parsed {
            Some(mut v) => {
                mutate_json(&mut v, rng);
                *target = serde_json::to_vec(&v).unwrap();
            }
            None => mutate_bytes(target, rng),
        }
    }
    (bytes, sidecar)
}

/// Loads (and when that works, builds and renders) one case: whether it loaded, or `Err` for
/// a broken invariant (a message that is not one line, a non-finite pixel).
fn run_case(dir: &Path, kind: Kind, bytes: &[u8], sidecar: Option<&[u8]>) -> Result<bool, String> {
    if kind == Kind::Sidecar {
        let p = dir.join("case.materials.json");
        std::fs::write(&p, bytes).unwrap();
        return match load_materials_file(&p, None) {
            Ok(_) => Ok(true),
            Err(e) => one_line(&e.to_string()),
        };
    }
    let p = dir.join(if kind == Kind::Glb {
        "case.glb"
    } else {
        "case.gltf"
    });
    std::fs::write(&p, bytes).unwrap();
    let side = dir.join("case.materials.json");
    match sidecar {
        Some(s) => std::fs::write(&side, s).unwrap(),
        None => {
            let _ = std::fs::remove_file(&side);
        }
    }
    let desc = match load_scene(&p, None, None) {
        Ok(d) => d,
        Err(e) => return one_line(&e.to_string()),
    };
    let scene = match Scene::build(desc) {
        Ok(s) => s,
        Err(e) => return one_line(&e.to_string()),
    };
    let settings = RenderSettings {
        width: 4,
        height: 3,
        spp: 1,
        max_depth: 4,
        ..Default::default()
    };
    let (film, _) = render_quiet(&scene, &settings);
    if film.to_rgba().iter().flatten().all(|v| v.is_finite()) {
        Ok(true)
    } else {
        Err("non-finite pixel".into())
    }
}

fn one_line(msg: &str) -> Result<bool, String> {
    if msg.contains('\n') || msg.is_empty() {
        Err(format!("error message is not one line: {msg:?}"))
    } else {
        Ok(false)
    }
}

#[test]
fn mutated_scenes_and_sidecars_never_panic_hang_or_write_non_finite_pixels() {
    let seconds: u64 = std::env::var("PRISM_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let seed: u64 = std::env::var("PRISM_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed);
    let base = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz_loader");
    let work = base.join("work");
    std::fs::create_dir_all(&work).unwrap();
    let seeds = seeds();
    assert!(seeds.len() > 80, "{} seeds", seeds.len());
    let mut rng = Rng(Pcg32::new(0, 0, seed));
    let start = Instant::now();
    let mut executions = 0u64;
    let mut loaded = 0u64;
    while start.elapsed() < Duration::from_secs(seconds) {
        let s = &seeds[rng.below(seeds.len())];
        let (bytes, sidecar) = mutate(s, &mut rng);
        let kind = s.kind;
        let (tx, rx) = mpsc::channel();
        let (w, b, sc) = (work.clone(), bytes.clone(), sidecar.clone());
        std::thread::spawn(move || {
            let r = std::panic::catch_unwind(|| run_case(&w, kind, &b, sc.as_deref()));
            let _ = tx.send(r);
        });
        let failure = match rx.recv_timeout(CASE_TIMEOUT) {
            Ok(Ok(Ok(ok))) => {
                loaded += u64::from(ok);
                None
            }
            Ok(Ok(Err(e))) => Some(e),
            Ok(Err(_)) => Some("panicked".to_string()),
            Err(_) => Some(format!("ran longer than {CASE_TIMEOUT:?}")),
        };
        executions += 1;
        if let Some(why) = failure {
            let dir = base.join("failures");
            std::fs::create_dir_all(&dir).unwrap();
            let ext = match kind {
                Kind::Gltf => "gltf",
                Kind::Glb => "glb",
                Kind::Sidecar => "materials.json",
            };
            let p = dir.join(format!("case_{executions}.{ext}"));
            std::fs::write(&p, &bytes).unwrap();
            if let Some(sc) = &sidecar {
                std::fs::write(dir.join(format!("case_{executions}.materials.json")), sc).unwrap();
            }
            panic!("{why}: input kept at {}", p.display());
        }
    }
    eprintln!(
        "fuzz_loader: {executions} executions ({loaded} loaded) in {:.1} s ({} seeds, seed {seed:#x})",
        start.elapsed().as_secs_f64(),
        seeds.len()
    );
    assert!(executions > 0);
}
