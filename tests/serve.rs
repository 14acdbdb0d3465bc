//! `prism serve` through its protocol (`src/serve.rs`): frames of a session equal final renders
//! of the scene as edited, edits restart the render, bad commands are errors the session
//! survives.

use glam::{Mat4, Vec3};
use prism::geometry::BvhLayout;
use prism::render::render_quiet;
use prism::scene::{load_scene, Scene, SceneDesc};
use prism::serve::{serve, session_settings};
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};

const W: u32 = 48;
const H: u32 = 36;
const SPP: u32 = 4;

fn everyday() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/everyday/everyday.gltf")
}

/// A session on pipes: commands in, events and frames out.
struct Session {
    commands: std::io::PipeWriter,
    events: BufReader<std::io::PipeReader>,
    server: Option<std::thread::JoinHandle<prism::error::Result<()>>>,
}

impl Session {
    fn start() -> Session {
        let (cmd_r, cmd_w) = std::io::pipe().unwrap();
        let (ev_r, ev_w) = std::io::pipe().unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let server = std::thread::spawn(move || serve(BufReader::new(cmd_r), ev_w, pool));
        let mut s = Session {
            commands: cmd_w,
            events: BufReader::new(ev_r),
            server: Some(server),
        };
        let (ready, _) = s.event();
        assert_eq!(ready["event"], "ready");
        s
    }

    fn send(&mut self, command: Value) {
        writeln!(self.commands, "{command}").unwrap();
        self.commands.flush().unwrap();
    }

    fn send_raw(&mut self, line: &str) {
        writeln!(self.commands, "{line}").unwrap();
    }

    /// The next event, with its frame's RGBA pixels (bottom row first) if it is a frame.
    fn event(&mut self) -> (Value, Option<Vec<f32>>) {
        let mut line = String::new();
        assert!(
            self.events.read_line(&mut line).unwrap() > 0,
            "stream ended"
        );
        let ev: Value = serde_json::from_str(&line).unwrap();
        if ev["event"] != "frame" {
            return (ev, None);
        }
        let mut bytes = vec![0u8; ev["bytes"].as_u64().unwrap() as usize];
        self.events.read_exact(&mut bytes).unwrap();
        let px = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        (ev, Some(px))
    }

    /// Events up to the next `done`; returns them and the last frame.
    fn until_done(&mut self) -> (Vec<Value>, Vec<f32>) {
        let mut events = Vec::new();
        let mut last = None;
        loop {
            let (ev, px) = self.event();
            if px.is_some() {
                last = px;
            }
            let done = ev["event"] == "done";
            events.push(ev);
            if done {
                return (events, last.expect("a frame before done"));
            }
        }
    }

    fn quit(mut self) {
        self.send(json!({"cmd": "quit"}));
        let result = self.server.take().unwrap().join().unwrap();
        assert!(result.is_ok());
    }
}

/// The image a final render of `desc` gives with the session's settings, bottom row first.
fn reference(desc: SceneDesc) -> Vec<f32> {
    let scene = Scene::build_with_layout(desc, BvhLayout::TwoLevel).unwrap();
    let settings = session_settings(&scene, W, H, SPP, None);
    let (film, _) = render_quiet(&scene, &settings);
    let rgba = film.to_rgba();
    rgba.chunks(W as usize)
        .rev()
        .flat_map(|row| row.iter().flatten().copied())
        .collect()
}

fn max_difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// A copy of the everyday scene's glTF, edited, in a fresh folder (its buffer still the
/// original's): (folder, file).
fn edited_everyday(tag: &str, edit: impl FnOnce(&mut Value)) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("prism_serve_test_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut gltf: Value =
        serde_json::from_str(&std::fs::read_to_string(everyday()).unwrap()).unwrap();
    gltf["buffers"][0]["uri"] = json!(everyday().parent().unwrap().join("everyday.bin"));
    edit(&mut gltf);
    let path = dir.join(format!("{tag}.gltf"));
    std::fs::write(&path, gltf.to_string()).unwrap();
    (dir, path)
}

fn open_session() -> Session {
    let mut s = Session::start();
    s.send(json!({"cmd": "settings", "samples": SPP, "start_resolution": 0}));
    s.send(json!({"cmd": "load", "scene": everyday()}));
    s.send(json!({"cmd": "view", "width": W, "height": H}));
    s
}

#[test]
fn frames_are_the_final_render_of_the_scene() {
    let mut s = open_session();
    let (events, frame) = s.until_done();
    let loaded = events.iter().find(|e| e["event"] == "loaded").unwrap();
    assert!(loaded["warnings"].as_array().unwrap().is_empty());
    // Passes of at most 4 samples: one frame each at 1, 2 and 4 spp.
    let spps: Vec<u64> = events
        .iter()
        .filter(|e| e["event"] == "frame")
        .map(|e| e["spp"].as_u64().unwrap())
        .collect();
    assert_eq!(spps, vec![1, 2, 4]);
    let expected = reference(load_scene(&everyday(), None, None).unwrap());
    assert_eq!(max_difference(&frame, &expected), 0.0);
    s.quit();
}

#[test]
fn a_moved_object_renders_as_if_loaded_there() {
    let mut s = open_session();
    s.until_done();
    let mut desc = load_scene(&everyday(), None, None).unwrap();
    let monkey = desc
        .instances
        .iter_mut()
        .find(|i| i.name == "Suzanne")
        .unwrap();
    let moved = Mat4::from_translation(Vec3::new(0.4, 0.3, -0.2)) * monkey.object_to_world;
    monkey.object_to_world = moved;
    s.send(json!({"cmd": "transform",
        "objects": [{"name": "Suzanne", "matrix": moved.to_cols_array()}]}));
    let (events, frame) = s.until_done();
    assert!(events
        .iter()
        .any(|e| e["event"] == "ok" && e["cmd"] == "transform"));
    let before = reference(load_scene(&everyday(), None, None).unwrap());
    let after = reference(desc);
    assert!(max_difference(&before, &after) > 0.1, "the move shows");
    assert_eq!(max_difference(&frame, &after), 0.0);
    s.quit();
}

#[test]
fn a_shading_edit_renders_as_if_loaded_with_it() {
    // The same scene with a blue ball where the red one was, a brighter sun and a blue world.
    let (dir, edited) = edited_everyday("shading", |gltf| {
        for m in gltf["materials"].as_array_mut().unwrap() {
            if m["name"] == "RedPlastic" {
                m["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.05, 0.1, 0.9, 1.0]);
            }
        }
        let lights = &mut gltf["extensions"]["KHR_lights_punctual"]["lights"];
        for l in lights.as_array_mut().unwrap() {
            l["intensity"] = json!(l["intensity"].as_f64().unwrap() * 1.5);
        }
    });
    let src_dir = everyday().parent().unwrap().to_path_buf();
    let mut materials: Value = serde_json::from_str(
        &std::fs::read_to_string(src_dir.join("everyday.materials.json")).unwrap(),
    )
    .unwrap();
    materials["world"] = json!({"color": [0.2, 0.3, 0.8], "strength": 1.0});
    let edited_json = dir.join("edited.materials.json");
    std::fs::write(&edited_json, materials.to_string()).unwrap();

    let mut s = open_session();
    s.until_done();
    s.send(json!({"cmd": "shading", "scene": edited, "materials": edited_json}));
    let (_, frame) = s.until_done();
    let before = reference(load_scene(&everyday(), None, None).unwrap());
    let mut desc = load_scene(&edited, Some(&edited_json), None).unwrap();
    // The session keeps the first load's render defaults; so does the reference.
    desc.render = load_scene(&everyday(), None, None).unwrap().render;
    let after = reference(desc);
    assert!(max_difference(&before, &after) > 0.1, "the edit shows");
    assert_eq!(max_difference(&frame, &after), 0.0);
    s.quit();
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_commands_are_errors_and_the_session_goes_on() {
    let mut s = Session::start();
    s.send(json!({"cmd": "view", "width": W, "height": H}));
    let (ev, _) = s.event();
    assert_eq!(ev["event"], "error");
    assert!(ev["message"]
        .as_str()
        .unwrap()
        .contains("no scene is loaded"));
    s.send_raw("{not json");
    s.send(json!({"cmd": "teleport"}));
    s.send(json!({"cmd": "settings", "samples": 4, "colour": "red"}));
    s.send(json!({"cmd": "load", "scene": "/nonexistent/scene.gltf"}));
    let mut messages = Vec::new();
    while messages.len() < 4 {
        let (ev, _) = s.event();
        if ev["event"] == "error" {
            messages.push(ev["message"].as_str().unwrap().to_string());
        }
    }
    assert!(messages[0].starts_with("bad command"), "{messages:?}");
    assert!(messages[1].contains("teleport"), "{messages:?}");
    assert!(messages[2].contains("colour"), "{messages:?}");
    assert!(
        messages[3].contains("/nonexistent/scene.gltf"),
        "{messages:?}"
    );
    // Still serving: a good scene renders, an unknown object is an error and moves nothing.
    s.send(json!({"cmd": "settings", "samples": 1, "start_resolution": 0}));
    s.send(json!({"cmd": "load", "scene": everyday()}));
    s.send(json!({"cmd": "view", "width": 8, "height": 8}));
    s.until_done();
    s.send(json!({"cmd": "transform",
        "objects": [{"name": "Nobody", "matrix": Mat4::IDENTITY.to_cols_array()}]}));
    let (events, _) = s.until_done();
    let error = events.iter().find(|e| e["event"] == "error").unwrap();
    assert!(error["message"].as_str().unwrap().contains("'Nobody'"));
    s.quit();
}

/// A viewport brings its own view: a scene without a camera loads, and renders once a view
/// with a camera arrives (a final render refuses such a scene).
#[test]
fn a_scene_without_a_camera_renders_from_the_view() {
    let (dir, path) = edited_everyday("nocam", |gltf| {
        gltf.as_object_mut().unwrap().remove("cameras");
        for n in gltf["nodes"].as_array_mut().unwrap() {
            n.as_object_mut().unwrap().remove("camera");
        }
    });
    assert!(
        load_scene(&path, None, None).is_err(),
        "a final render needs a camera"
    );
    let mut s = Session::start();
    s.send(json!({"cmd": "settings", "samples": 1, "start_resolution": 0}));
    s.send(json!({"cmd": "load", "scene": path}));
    let to_world = Mat4::from_translation(Vec3::new(0.0, 1.0, 6.0));
    s.send(json!({"cmd": "view", "width": 16, "height": 12,
        "camera": {"to_world": to_world.to_cols_array(), "yfov": 0.8}}));
    let (events, frame) = s.until_done();
    assert!(events.iter().all(|e| e["event"] != "error"), "{events:?}");
    assert!(frame.iter().any(|&v| v > 0.01), "the view sees the scene");
    s.quit();
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_end_of_input_ends_the_session_during_a_render() {
    let mut s = Session::start();
    s.send(json!({"cmd": "settings", "samples": 0}));
    s.send(json!({"cmd": "load", "scene": everyday()}));
    s.send(json!({"cmd": "view", "width": 64, "height": 64}));
    // Endless sampling is running once a full-size frame is out.
    loop {
        let (ev, _) = s.event();
        if ev["event"] == "frame" && ev["width"] == 64 {
            break;
        }
    }
    let Session {
        commands,
        mut server,
        events,
    } = s;
    drop(commands);
    // Keep reading, so a frame being written does not block the server on a full pipe.
    let drain = std::thread::spawn(move || std::io::copy(&mut { events }, &mut std::io::sink()));
    let result = server.take().unwrap().join().unwrap();
    assert!(result.is_ok());
    drain.join().unwrap().unwrap();
}
