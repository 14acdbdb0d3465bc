//! The glTF JSON as the renderer reads it: valid files that the `gltf` crate's JSON model
//! cannot hold are brought into a form it can, before it deserializes them.
//!
//! The glTF 2.0 schema allows, and real exporters write, JSON that `gltf-json` 1.4 refuses at
//! deserialization:
//! * integers written as floats (`"count": 3.0`): JSON has one number type, and the glTF
//!   validator accepts them (`integer_written_as_float`);
//! * textures without `source` whose image comes from an extension (`EXT_texture_webp`,
//!   `KHR_texture_basisu`, `MSFT_texture_dds`, ...; glTF 2.0 spec 5.29: "When undefined, an
//!   extension or other mechanism SHOULD supply an alternate texture source");
//! * animation channels without `node` (`KHR_animation_pointer`).
//!
//! [`prepare`] rewrites those in a `serde_json::Value` and records what the rewrite hides (which
//! texture reads which image through which extension, which lights are of a type this renderer
//! does not know) so the importer can warn and fall back instead of failing. Nothing here
//! validates: the importer checks exactly the objects it uses (`gltf_import.rs`).

use serde_json::{Map, Value};

/// Where a texture's texels come from.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureSource {
    /// An image the renderer decodes (PNG, JPEG, and WebP through `EXT_texture_webp`); the
    /// texture's `source` holds its index after [`prepare`].
    Image(usize),
    /// No image the renderer can decode (KTX2/Basis, DDS, AVIF, no source at all): the slot
    /// falls back to its factor, with a warning naming this reason.
    Unsupported(String),
}

/// The deserialized root plus what [`prepare`] learned on the way.
pub struct PreparedJson {
    pub root: gltf::json::Root,
    /// By texture index.
    pub texture_sources: Vec<TextureSource>,
    /// Lights of a type from a future extension revision: (index, type), skipped with a warning.
    pub unknown_lights: Vec<(usize, String)>,
    pub warnings: Vec<String>,
}

/// Image-source extensions of textures and whether the renderer decodes their images.
const TEXTURE_SOURCE_EXTENSIONS: &[(&str, bool)] = &[
    ("EXT_texture_webp", true),
    ("KHR_texture_basisu", false),
    ("MSFT_texture_dds", false),
    ("EXT_texture_avif", false),
];

/// Parses glTF JSON text into the `gltf` crate's model, tolerating the valid forms it cannot
/// represent (module docs). Errors are one line naming the JSON path of the problem.
pub fn prepare(json: &[u8]) -> Result<PreparedJson, String> {
    // A UTF-8 byte order mark is not allowed (glTF 2.0 spec 3.2) but harmless: editors on
    // Windows write one.
    let json = json.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json);
    let mut value: Value =
        serde_json::from_slice(json).map_err(|e| format!("invalid glTF JSON: {e}"))?;
    let Some(obj) = value.as_object_mut() else {
        return Err("invalid glTF JSON: the top level is not an object".into());
    };
    let mut warnings = Vec::new();

    // A still renderer shows the rest pose; animations are also where KHR_animation_pointer
    // channels without `node` live.
    if let Some(anims) = obj.remove("animations") {
        let n = anims.as_array().map_or(0, Vec::len);
        if n > 0 {
            let s = if n == 1 { "" } else { "s" };
            warnings.push(format!(
                "{n} animation{s} ignored: the scene is rendered in its rest pose"
            ));
        }
    }
    let texture_sources = prepare_textures(obj);
    let unknown_lights = prepare_lights(obj);
    integers_from_integral_floats(&mut value);

    let root: gltf::json::Root = serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        format!("invalid glTF: {path}: {}", e.into_inner())
    })?;
    Ok(PreparedJson {
        root,
        texture_sources,
        unknown_lights,
        warnings,
    })
}

/// Picks each texture's image: an extension's image the renderer decodes, else the core
/// `source` (the fallback for viewers without the extension), else none. A texture without
/// `source` gets a placeholder index 0 so the crate can hold it; [`TextureSource`] says the
/// truth.
fn prepare_textures(obj: &mut Map<String, Value>) -> Vec<TextureSource> {
    let Some(textures) = obj.get_mut("textures").and_then(Value::as_array_mut) else {
        return Vec::new();
    };
    let index = |v: Option<&Value>| {
        v.and_then(Value::as_f64)
            .filter(|x| *x >= 0.0 && x.fract() == 0.0)
    };
    textures
        .iter_mut()
        .map(|tex| {
            let Some(t) = tex.as_object_mut() else {
                return TextureSource::Unsupported("not a JSON object".into());
            };
            let core = index(t.get("source"));
            let exts = t.get("extensions").and_then(Value::as_object);
            let mut undecodable: Option<&str> = None;
            let mut chosen = None;
            for (name, decodable) in TEXTURE_SOURCE_EXTENSIONS {
                let Some(src) = exts.and_then(|e| e.get(*name)) else {
                    continue;
                };
                if *decodable {
                    if let Some(i) = index(src.get("source")) {
                        chosen = Some(i);
                        break;
                    }
                } else {
                    undecodable.get_or_insert(name);
                }
            }
            let chosen = chosen.or(core);
            match chosen {
                Some(i) => {
                    t.insert("source".into(), Value::from(i as u64));
                    TextureSource::Image(i as usize)
                }
                None => {
                    t.insert("source".into(), Value::from(0u64));
                    TextureSource::Unsupported(match undecodable {
                        Some(ext) => format!("its image is only given through {ext}, which is not supported"),
                        None => "it has no image ('source' is undefined and no known extension supplies one)".into(),
                    })
                }
            }
        })
        .collect()
}

/// KHR_lights_punctual: lights of an unknown type are recorded and made points (so the crate
/// holds them; the importer skips them), spot lights without a `spot` object get the
/// extension's defaults.
fn prepare_lights(obj: &mut Map<String, Value>) -> Vec<(usize, String)> {
    let mut unknown = Vec::new();
    let lights = obj
        .get_mut("extensions")
        .and_then(|e| e.get_mut("KHR_lights_punctual"))
        .and_then(|l| l.get_mut("lights"))
        .and_then(Value::as_array_mut);
    let Some(lights) = lights else {
        return unknown;
    };
    for (i, light) in lights.iter_mut().enumerate() {
        let Some(l) = light.as_object_mut() else {
            continue;
        };
        let kind = l.get("type").and_then(Value::as_str).map(str::to_string);
        match kind.as_deref() {
            Some("point") | Some("directional") => {}
            Some("spot") => {
                l.entry("spot").or_insert_with(|| Value::Object(Map::new()));
            }
            Some(other) => {
                unknown.push((i, other.to_string()));
                l.insert("type".into(), Value::from("point"));
                l.remove("spot");
            }
            None => {} // missing `type`: the deserializer names it
        }
    }
    unknown
}

/// Integral floats (`3.0`) become integers (`3`) everywhere: serde reads an integer into an
/// `f32` field as well, but not a float into an index or a count. Only values an `f64`
/// represents exactly are touched.
fn integers_from_integral_floats(v: &mut Value) {
    const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
    match v {
        Value::Number(n) if !n.is_i64() && !n.is_u64() => {
            if let Some(x) = n.as_f64() {
                if x.fract() == 0.0 && x.abs() <= EXACT {
                    *v = if x >= 0.0 {
                        Value::from(x as u64)
                    } else {
                        Value::from(x as i64)
                    };
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(integers_from_integral_floats),
        Value::Object(o) => o.values_mut().for_each(integers_from_integral_floats),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_floats_become_integers_and_others_stay() {
        let mut v: Value =
            serde_json::from_str(r#"{"a": 3.0, "b": [1.5, -2.0, 0.0], "c": 7}"#).unwrap();
        integers_from_integral_floats(&mut v);
        assert_eq!(v["a"], Value::from(3u64));
        assert_eq!(v["b"][0].as_f64(), Some(1.5));
        assert_eq!(v["b"][1], Value::from(-2i64));
        assert_eq!(v["b"][2], Value::from(0u64));
        assert_eq!(v["c"], Value::from(7u64));
    }

    #[test]
    fn texture_sources_prefer_decodable_extensions_then_the_core_source() {
        let mut v: Value = serde_json::from_str(
            r#"{"textures": [
                {"source": 0},
                {"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}},
                {"extensions": {"KHR_texture_basisu": {"source": 2}}},
                {"source": 3, "extensions": {"KHR_texture_basisu": {"source": 2}}},
                {}
            ]}"#,
        )
        .unwrap();
        let s = prepare_textures(v.as_object_mut().unwrap());
        assert_eq!(s[0], TextureSource::Image(0));
        assert_eq!(s[1], TextureSource::Image(1));
        assert!(matches!(&s[2], TextureSource::Unsupported(m) if m.contains("KHR_texture_basisu")));
        assert_eq!(s[3], TextureSource::Image(3));
        assert!(matches!(&s[4], TextureSource::Unsupported(m) if m.contains("no image")));
        assert_eq!(v["textures"][2]["source"], Value::from(0u64));
    }

    #[test]
    fn unknown_light_types_are_recorded() {
        let mut v: Value = serde_json::from_str(
            r#"{"extensions": {"KHR_lights_punctual": {"lights": [
                {"type": "point"}, {"type": "area_future"}, {"type": "spot"}
            ]}}}"#,
        )
        .unwrap();
        let u = prepare_lights(v.as_object_mut().unwrap());
        assert_eq!(u, vec![(1, "area_future".to_string())]);
        let lights = &v["extensions"]["KHR_lights_punctual"]["lights"];
        assert_eq!(lights[1]["type"], Value::from("point"));
        assert!(lights[2]["spot"].is_object());
    }

    #[test]
    fn a_byte_order_mark_is_skipped() {
        let p = prepare(b"\xEF\xBB\xBF{\"asset\": {\"version\": \"2.0\"}}");
        assert!(p.is_ok());
    }

    #[test]
    fn type_errors_name_the_json_path() {
        let e = match prepare(br#"{"asset": {"version": "2.0"}, "accessors": [{"componentType": 5126, "count": 1.5, "type": "SCALAR"}]}"#) {
            Err(e) => e,
            Ok(_) => panic!("a fractional count must fail"),
        };
        assert!(e.contains("accessors[0].count"), "{e}");
    }
}
