//! The `prism` binary's contract: JSON progress lines, the EXR it writes, interruption.

use prism::film::read_exr_rgba;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn prism() -> Command {
    Command::new(env!("CARGO_BIN_EXE_prism"))
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prism-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json_lines(stderr: &str) -> Vec<serde_json::Value> {
    stderr
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

#[test]
fn render_writes_exr_and_json_progress() {
    let dir = temp_dir("render");
    let out = dir.join("c.exr");
    let preview = dir.join("preview.exr");
    let o = prism()
        .args([
            "render",
            "scenes/cornell/cornell.gltf",
            "--spp",
            "8",
            "--width",
            "40",
            "--height",
            "30",
        ])
        .args(["--progress", "json", "--threads", "2", "-o"])
        .arg(&out)
        .arg("--preview")
        .arg(&preview)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "prism failed: {stderr}");
    let events = json_lines(&stderr);
    let kinds: Vec<&str> = events.iter().filter_map(|e| e["event"].as_str()).collect();
    assert_eq!(kinds.first(), Some(&"start"), "{stderr}");
    assert_eq!(kinds.last(), Some(&"done"), "{stderr}");
    assert!(kinds.contains(&"preview") && preview.exists());
    let progress: Vec<&serde_json::Value> =
        events.iter().filter(|e| e["event"] == "progress").collect();
    assert!(!progress.is_empty());
    for p in &progress {
        let f = p["fraction"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&f));
        assert!(p["samples_done"].as_u64().is_some() && p["elapsed_s"].as_f64().is_some());
    }
    assert_eq!(progress.last().unwrap()["fraction"].as_f64().unwrap(), 1.0);
    let done = events.last().unwrap();
    assert!(done["rays"].as_u64().unwrap() >= 40 * 30 * 8);
    assert_eq!(done["samples"].as_u64().unwrap(), 40 * 30 * 8);
    assert!(done["seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(done["cancelled"], false);

    let (w, h, px) = read_exr_rgba(&out).unwrap();
    assert_eq!((w, h), (40, 30));
    assert!(px
        .iter()
        .all(|p| p.iter().all(|v| v.is_finite()) && p[3] == 1.0));
    let mean: f32 = px.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / (3 * px.len()) as f32;
    assert!(mean > 0.05 && mean < 2.0, "implausible mean {mean}");
    std::fs::remove_dir_all(dir).ok();
}

#[cfg(unix)]
#[test]
fn sigint_stops_quickly_and_writes_partial_image() {
    let dir = temp_dir("sigint");
    let out = dir.join("partial.exr");
    let mut child = prism()
        .args([
            "render",
            "scenes/cornell/cornell.gltf",
            "--spp",
            "100000",
            "--width",
            "64",
            "--height",
            "64",
        ])
        .args(["--progress", "json", "--threads", "2", "-o"])
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    // Wait until the first finished pass, so there is something to write.
    let mut saw_pass = false;
    for line in lines.by_ref() {
        let line = line.unwrap();
        if line.contains("\"pass_spp\"") {
            saw_pass = true;
            break;
        }
    }
    assert!(saw_pass, "no progress before the stream ended");
    let t0 = Instant::now();
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let rest: Vec<String> = lines.map_while(|l| l.ok()).collect();
    let exit = child.wait().unwrap();
    let took = t0.elapsed();
    assert!(took < Duration::from_millis(1500), "took {took:?} to stop");
    assert!(exit.success(), "exit status {exit:?}");
    let done: Vec<serde_json::Value> = rest
        .iter()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let done = done
        .iter()
        .find(|e| e["event"] == "done")
        .expect("done event");
    assert_eq!(done["cancelled"], true);
    let (w, h, px) = read_exr_rgba(&out).unwrap();
    assert_eq!((w, h), (64, 64));
    assert!(px.iter().all(|p| p.iter().all(|v| v.is_finite())));
    assert!(px.iter().any(|p| p[0] > 0.0), "partial image is black");
    std::fs::remove_dir_all(dir).ok();
}

/// `--exr-compression`: the three encodings hold the same pixels (the render is deterministic
/// per pixel), `none` is the raw size and is what the add-on's numpy reader takes; guides too.
#[test]
fn exr_compression_choices_hold_the_same_pixels() {
    let dir = temp_dir("compression");
    let mut images = Vec::new();
    for (c, guides) in [
        ("rle", false),
        ("zip", false),
        ("none", false),
        ("none", true),
    ] {
        let out = dir.join(format!("{c}{guides}.exr"));
        let mut cmd = prism();
        cmd.args([
            "render",
            "scenes/cornell/cornell.gltf",
            "--spp",
            "4",
            "--width",
            "48",
            "--height",
            "36",
            "--threads",
            "2",
            "--progress",
            "none",
            "--exr-compression",
            c,
            "-o",
        ])
        .arg(&out);
        if guides {
            cmd.arg("--guides");
        }
        let o = cmd.output().unwrap();
        assert!(
            o.status.success(),
            "{c}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (w, h, px) = read_exr_rgba(&out).unwrap();
        assert_eq!((w, h), (48, 36));
        images.push((c, px, std::fs::metadata(&out).unwrap().len()));
    }
    for (c, px, _) in &images[1..] {
        assert!(px == &images[0].1, "{c} pixels differ from rle");
    }
    let raw = 48 * 36 * 4 * 4;
    let (zip, none, none_guides) = (images[1].2, images[2].2, images[3].2);
    assert!(
        none as usize > raw,
        "uncompressed holds every float: {none} bytes"
    );
    assert!(
        none_guides as usize > 11 * raw / 4,
        "guides uncompressed: {none_guides} bytes"
    );
    assert!(zip < none, "zip {zip} bytes < none {none}");
    let bad = prism()
        .args([
            "render",
            "scenes/cornell/cornell.gltf",
            "--exr-compression",
            "lzma",
        ])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_output_folder_is_made_and_an_impossible_one_fails_before_the_render() {
    let dir = temp_dir("folders");
    // A folder that does not exist yet, two levels deep, for the image and the preview.
    let out = dir.join("renders").join("today").join("c.exr");
    let preview = dir.join("previews").join("p.exr");
    let render = |out: &std::path::Path| {
        prism()
            .args(["render", "scenes/cornell/cornell.gltf", "--spp", "2"])
            .args([
                "--width",
                "16",
                "--height",
                "12",
                "--progress",
                "none",
                "-o",
            ])
            .arg(out)
            .arg("--preview")
            .arg(&preview)
            .output()
            .unwrap()
    };
    let o = render(&out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_exr_rgba(&out).unwrap().0, 16);
    assert!(preview.exists());
    // Under a file: exit 2 with one line naming the folder, and no render.
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let o = render(&file.join("c.exr"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("a-file") && stderr.contains("cannot create the folder"));
    assert!(!stderr.contains("rendered"), "{stderr}");
    std::fs::remove_dir_all(dir).ok();
}
