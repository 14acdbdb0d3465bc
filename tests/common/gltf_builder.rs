//! A tiny glTF 2.0 document builder for tests: geometry goes into one binary buffer, written
//! either embedded (base64 data URI), as an external `.bin`, or as a `.glb`.
//!
//! Include it with `#[path = "common/gltf_builder.rs"] mod gltf_builder;`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

pub const TRIANGLES: u32 = 4;
pub const TRIANGLE_STRIP: u32 = 5;
pub const TRIANGLE_FAN: u32 = 6;
pub const POINTS: u32 = 0;
pub const LINES: u32 = 1;

#[derive(Default, Clone)]
pub struct GltfBuilder {
    pub bin: Vec<u8>,
    pub buffer_views: Vec<Value>,
    pub accessors: Vec<Value>,
    pub meshes: Vec<Value>,
    pub materials: Vec<Value>,
    pub nodes: Vec<Value>,
    pub cameras: Vec<Value>,
    pub lights: Vec<Value>,
    pub images: Vec<Value>,
    pub textures: Vec<Value>,
    pub samplers: Vec<Value>,
    pub scene_nodes: Vec<usize>,
    pub extensions_used: Vec<String>,
}

impl GltfBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends bytes (4-byte aligned) and a buffer view over them; returns the view index.
    pub fn push_view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.buffer_views.push(json!({
            "buffer": 0, "byteOffset": offset, "byteLength": bytes.len()
        }));
        self.buffer_views.len() - 1
    }

    fn push_accessor(&mut self, acc: Value) -> usize {
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// POSITION accessor (with the min/max glTF requires).
    pub fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for v in p {
            for k in 0..3 {
                if v[k].is_finite() {
                    min[k] = min[k].min(v[k]);
                    max[k] = max[k].max(v[k]);
                }
            }
        }
        for k in 0..3 {
            if !min[k].is_finite() {
                min[k] = 0.0;
                max[k] = 0.0;
            }
        }
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC3",
            "min": min, "max": max
        }))
    }

    pub fn vec3(&mut self, p: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC3"
        }))
    }

    pub fn vec2(&mut self, p: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC2"
        }))
    }

    pub fn vec4(&mut self, p: &[[f32; 4]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC4"
        }))
    }

    pub fn indices_u16(&mut self, i: &[u16]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5123, "count": i.len(), "type": "SCALAR"
        }))
    }

    pub fn indices_u32(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.push_accessor(json!({
            "bufferView": view, "componentType": 5125, "count": i.len(), "type": "SCALAR"
        }))
    }

    /// A primitive object: POSITION accessor, optional indices, material and mode.
    pub fn prim(pos: usize, indices: Option<usize>, material: Option<usize>, mode: u32) -> Value {
        let mut p = json!({ "attributes": { "POSITION": pos }, "mode": mode });
        if let Some(i) = indices {
            p["indices"] = json!(i);
        }
        if let Some(m) = material {
            p["material"] = json!(m);
        }
        p
    }

    pub fn mesh(&mut self, name: &str, primitives: Vec<Value>) -> usize {
        self.meshes
            .push(json!({ "name": name, "primitives": primitives }));
        self.meshes.len() - 1
    }

    pub fn material(&mut self, m: Value) -> usize {
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// An emissive material (emissiveFactor 1 x `strength`).
    pub fn emissive_material(&mut self, name: &str, strength: f32) -> usize {
        self.use_ext("KHR_materials_emissive_strength");
        self.material(json!({
            "name": name,
            "emissiveFactor": [1.0, 1.0, 1.0],
            "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": strength } }
        }))
    }

    pub fn node(&mut self, n: Value) -> usize {
        self.nodes.push(n);
        self.nodes.len() - 1
    }

    /// A node that is a root of the scene.
    pub fn root(&mut self, n: Value) -> usize {
        let i = self.node(n);
        self.scene_nodes.push(i);
        i
    }

    pub fn camera(&mut self, name: &str, yfov: f32, aspect: Option<f32>) -> usize {
        let mut p = json!({ "yfov": yfov, "znear": 0.01 });
        if let Some(a) = aspect {
            p["aspectRatio"] = json!(a);
        }
        self.cameras
            .push(json!({ "name": name, "type": "perspective", "perspective": p }));
        self.cameras.len() - 1
    }

    pub fn light(&mut self, l: Value) -> usize {
        self.use_ext("KHR_lights_punctual");
        self.lights.push(l);
        self.lights.len() - 1
    }

    /// An image stored in the binary buffer.
    pub fn image_embedded(&mut self, bytes: &[u8], mime: &str) -> usize {
        let view = self.push_view(bytes);
        self.images
            .push(json!({ "bufferView": view, "mimeType": mime }));
        self.images.len() - 1
    }

    pub fn image_uri(&mut self, uri: &str) -> usize {
        self.images.push(json!({ "uri": uri }));
        self.images.len() - 1
    }

    pub fn texture(&mut self, image: usize, sampler: Option<Value>) -> usize {
        let mut t = json!({ "source": image });
        if let Some(s) = sampler {
            self.samplers.push(s);
            t["sampler"] = json!(self.samplers.len() - 1);
        }
        self.textures.push(t);
        self.textures.len() - 1
    }

    pub fn use_ext(&mut self, ext: &str) {
        if !self.extensions_used.iter().any(|e| e == ext) {
            self.extensions_used.push(ext.to_string());
        }
    }

    /// A unit quad in the z = 0 plane facing +z (two triangles, indexed).
    pub fn quad_mesh(&mut self, name: &str, material: Option<usize>) -> usize {
        let pos = self.positions(&[
            [-0.5, -0.5, 0.0],
            [0.5, -0.5, 0.0],
            [0.5, 0.5, 0.0],
            [-0.5, 0.5, 0.0],
        ]);
        let idx = self.indices_u16(&[0, 1, 2, 0, 2, 3]);
        self.mesh(name, vec![Self::prim(pos, Some(idx), material, TRIANGLES)])
    }

    /// A minimal renderable scene: an emissive quad ("Light", material "Emitter") and a camera
    /// node "Camera" at z = 3 looking down -z.
    pub fn basic() -> Self {
        let mut b = Self::new();
        let m = b.emissive_material("Emitter", 5.0);
        let q = b.quad_mesh("Light", Some(m));
        b.root(json!({ "name": "Light", "mesh": q }));
        let c = b.camera("CameraData", 0.7, None);
        b.root(json!({ "name": "Camera", "camera": c, "translation": [0.0, 0.0, 3.0] }));
        b
    }

    fn document(&self, buffer: Option<Value>) -> Value {
        let mut root = Map::new();
        root.insert(
            "asset".into(),
            json!({ "version": "2.0", "generator": "prism tests" }),
        );
        root.insert("scene".into(), json!(0));
        root.insert("scenes".into(), json!([{ "nodes": self.scene_nodes }]));
        let mut put = |k: &str, v: &Vec<Value>| {
            if !v.is_empty() {
                root.insert(k.into(), Value::Array(v.clone()));
            }
        };
        put("nodes", &self.nodes);
        put("meshes", &self.meshes);
        put("materials", &self.materials);
        put("cameras", &self.cameras);
        put("accessors", &self.accessors);
        put("bufferViews", &self.buffer_views);
        put("images", &self.images);
        put("textures", &self.textures);
        put("samplers", &self.samplers);
        if let Some(b) = buffer {
            root.insert("buffers".into(), json!([b]));
        }
        if !self.extensions_used.is_empty() {
            root.insert("extensionsUsed".into(), json!(self.extensions_used));
        }
        if !self.lights.is_empty() {
            root.insert(
                "extensions".into(),
                json!({ "KHR_lights_punctual": { "lights": self.lights } }),
            );
        }
        Value::Object(root)
    }

    fn has_buffer(&self) -> bool {
        !self.buffer_views.is_empty()
    }

    /// The document with the buffer embedded as a base64 data URI.
    pub fn to_json(&self) -> Value {
        let buf = self.has_buffer().then(|| {
            json!({
                "byteLength": self.bin.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&self.bin))
            })
        });
        self.document(buf)
    }

    /// Writes `<path>` (embedded buffer).
    pub fn write_gltf(&self, path: &Path) -> PathBuf {
        std::fs::write(path, serde_json::to_string_pretty(&self.to_json()).unwrap()).unwrap();
        path.to_path_buf()
    }

    /// Writes `<path>` referencing an external buffer file `bin_uri` (written beside it unless
    /// `write_bin` is false).
    pub fn write_gltf_external(&self, path: &Path, bin_uri: &str, write_bin: bool) -> PathBuf {
        let doc = self.document(Some(
            json!({ "byteLength": self.bin.len(), "uri": bin_uri }),
        ));
        std::fs::write(path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
        if write_bin {
            std::fs::write(path.parent().unwrap().join(bin_uri), &self.bin).unwrap();
        }
        path.to_path_buf()
    }

    /// Binary glTF bytes.
    pub fn to_glb(&self) -> Vec<u8> {
        let buf = self
            .has_buffer()
            .then(|| json!({ "byteLength": self.bin.len() }));
        let mut json = serde_json::to_vec(&self.document(buf)).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut total = 12 + 8 + json.len();
        if self.has_buffer() {
            total += 8 + bin.len();
        }
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        if self.has_buffer() {
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&bin);
        }
        out
    }

    pub fn write_glb(&self, path: &Path) -> PathBuf {
        std::fs::write(path, self.to_glb()).unwrap();
        path.to_path_buf()
    }
}

/// Standard base64 with padding.
pub fn base64_encode(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        s.push(T[(n >> 18) as usize & 63] as char);
        s.push(T[(n >> 12) as usize & 63] as char);
        s.push(if c.len() > 1 {
            T[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        s.push(if c.len() > 2 {
            T[n as usize & 63] as char
        } else {
            '='
        });
    }
    s
}

/// A fresh, empty directory for one test under Cargo's per-target temporary directory.
pub fn test_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("scene_tests")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// PNG bytes of a `w` x `h` RGBA16 image (for data textures that need more than 8 bits,
/// e.g. an exactly flat normal map: 0.5 has no 8-bit code).
pub fn png16_bytes(w: u32, h: u32, rgba: &[[u16; 4]]) -> Vec<u8> {
    let img: image::ImageBuffer<image::Rgba<u16>, Vec<u16>> =
        image::ImageBuffer::from_fn(w, h, |x, y| image::Rgba(rgba[(y * w + x) as usize]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// PNG bytes of a `w` x `h` RGBA8 image.
pub fn png_bytes(w: u32, h: u32, rgba: &[[u8; 4]]) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(rgba[(y * w + x) as usize]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}
