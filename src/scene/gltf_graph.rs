//! glTF's textured material slots as a shading graph, so that the glTF path and Blender's node
//! graphs are one material system (`crate::shading`).
//!
//! A glTF material is constant factors (`GltfMaterialDesc`) times textures. The factors stay
//! constants of the material; every texture slot becomes the nodes Blender's own glTF importer
//! builds for it: UV Map (TEXCOORD_n) -> KHR_texture_transform -> Image Texture (the sampler's
//! wrap modes per axis and its filter) -> Separate Color for a channel -> Math / Vector Math
//! multiply by the factor, bound to the material input it drives (glTF 2.0 section 3.9 and the
//! KHR extensions for which channel feeds which input). A sidecar graph's own bindings win:
//! glTF's are fallbacks (`ShadingGraph::with_fallbacks`).

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3, Vec4};

use super::desc::{AlphaMode, GltfMaterialDesc, TextureDesc, TextureRef};
use crate::shading::graph::{
    blender_uv, ColorModel, GraphNode, MaterialInput, NodeOp, SocketType, Source,
};
use crate::shading::math_ops::{MathOp, VectorMathOp};
use crate::shading::MAX_ATTRIBUTE_SETS;

/// The v flip between glTF UVs (origin top-left) and Blender's (origin bottom-left) as an
/// affine 3x3 map: (u, v, 1) -> (u, 1 - v, 1). It is its own inverse.
const V_FLIP: Mat3 = Mat3::from_cols_array(&[1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 1.0]);

/// KHR_texture_transform's matrix (acting on glTF UVs) as a map of Blender UVs.
pub fn blender_uv_transform(gltf: Mat3) -> Mat3 {
    V_FLIP * gltf * V_FLIP
}

/// The texture lookup of a glTF slot at glTF UV `uv` of its TEXCOORD set: what the graph's
/// UV Transform + Image Texture nodes compute (used by the normal-map path, whose tangent
/// frame the integrator applies).
pub fn sample_slot(tex: &TextureDesc, r: &TextureRef, uv: Vec2) -> Vec4 {
    let b = blender_uv_transform(r.uv_transform) * blender_uv(uv).extend(1.0);
    tex.image
        .sample(Vec2::new(b.x, b.y), tex.interpolation(), tex.wrap)
}

/// Builds the nodes in evaluation order, with consecutive output slots from 0.
struct Builder<'a> {
    textures: &'a [TextureDesc],
    nodes: Vec<GraphNode>,
    next_slot: u32,
    /// (texture, TEXCOORD set, transform bits) -> the Image Texture node's first slot.
    lookups: HashMap<(usize, u32, [u32; 9]), u32>,
    /// Image Texture slot -> its Separate Color node's first slot.
    separated: HashMap<u32, u32>,
}

const F: SocketType = SocketType::Float;
const C: SocketType = SocketType::Color;
const V: SocketType = SocketType::Vector;

fn link(slot: u32, from: SocketType, to: SocketType) -> Source {
    Source::Link { slot, from, to }
}

impl Builder<'_> {
    fn add(&mut self, name: String, op: NodeOp, inputs: Vec<Source>) -> u32 {
        let first_slot = self.next_slot;
        self.next_slot += op.signature().outputs.len() as u32;
        self.nodes.push(GraphNode {
            name,
            op,
            inputs,
            first_slot,
        });
        first_slot
    }

    /// The Image Texture node of `r` (colour at the returned slot, alpha at the next); `None`
    /// for an invalid texture index (the slot then reads its factor alone).
    fn lookup(&mut self, slot: &str, r: &TextureRef) -> Option<u32> {
        let tex = self.textures.get(r.texture)?;
        // Sets past the loaded ones read TEXCOORD_0 (warned at import).
        let set = if (r.tex_coord as usize) < MAX_ATTRIBUTE_SETS {
            r.tex_coord
        } else {
            0
        };
        let key = (
            r.texture,
            set,
            r.uv_transform.to_cols_array().map(f32::to_bits),
        );
        if let Some(&s) = self.lookups.get(&key) {
            return Some(s);
        }
        let uv = self.add(
            format!("{slot} UV Map"),
            NodeOp::UvMap(set as usize),
            vec![],
        );
        let mut uv = link(uv, V, V);
        if r.uv_transform != Mat3::IDENTITY {
            let t = self.add(
                format!("{slot} texture transform"),
                NodeOp::UvTransform(blender_uv_transform(r.uv_transform)),
                vec![uv],
            );
            uv = link(t, V, V);
        }
        let image = self.add(
            format!("{slot} '{}'", tex.image.name),
            NodeOp::ImageTexture {
                image: Arc::clone(&tex.image),
                interpolation: tex.interpolation(),
                extension: tex.wrap,
            },
            vec![uv],
        );
        self.lookups.insert(key, image);
        Some(image)
    }

    /// Channel `channel` (0 R, 1 G, 2 B, 3 A) of `r`.
    fn channel(&mut self, slot: &str, r: &TextureRef, channel: usize) -> Option<Source> {
        let image = self.lookup(slot, r)?;
        if channel == 3 {
            return Some(link(image + 1, F, F));
        }
        let sep = match self.separated.get(&image) {
            Some(&s) => s,
            None => {
                let s = self.add(
                    format!("{slot} channels"),
                    NodeOp::SeparateColor(ColorModel::Rgb),
                    vec![link(image, C, C)],
                );
                self.separated.insert(image, s);
                s
            }
        };
        Some(link(sep + channel as u32, F, F))
    }

    /// `factor` times channel `channel` of `r`.
    fn scaled_channel(
        &mut self,
        slot: &str,
        r: &TextureRef,
        channel: usize,
        factor: f32,
    ) -> Option<Source> {
        let c = self.channel(slot, r, channel)?;
        if factor == 1.0 {
            return Some(c);
        }
        Some(self.multiply(slot, factor, c))
    }

    fn multiply(&mut self, slot: &str, factor: f32, value: Source) -> Source {
        let m = self.add(
            format!("{slot} factor"),
            NodeOp::Math {
                op: MathOp::Multiply,
                clamp: false,
            },
            vec![
                Source::Const(Vec4::splat(factor)),
                value,
                Source::Const(Vec4::ZERO),
            ],
        );
        link(m, F, F)
    }

    /// `factor` times the RGB of `r`.
    fn scaled_color(&mut self, slot: &str, r: &TextureRef, factor: Vec3) -> Option<Source> {
        let image = self.lookup(slot, r)?;
        if factor == Vec3::ONE {
            return Some(link(image, C, C));
        }
        let m = self.add(
            format!("{slot} factor"),
            NodeOp::VectorMath(VectorMathOp::Multiply),
            vec![
                link(image, C, V),
                Source::Const(factor.extend(0.0)),
                Source::Const(Vec4::ZERO),
                Source::Const(Vec4::ONE),
            ],
        );
        Some(link(m, V, C))
    }
}

/// The nodes and bindings of `g`'s texture slots (empty without textures). Normal and clear
/// coat normal textures are not bound: their tangent frame is applied by the integrator
/// (`Material::apply_normal_map`), reading the same lookup through [`sample_slot`].
pub fn texture_graph(
    g: &GltfMaterialDesc,
    textures: &[TextureDesc],
) -> (Vec<GraphNode>, Vec<(MaterialInput, Source)>) {
    let mut b = Builder {
        textures,
        nodes: Vec::new(),
        next_slot: 0,
        lookups: HashMap::new(),
        separated: HashMap::new(),
    };
    let mut bind = Vec::new();
    if let Some(t) = &g.base_color_texture {
        if let Some(c) = b.scaled_color("baseColorTexture", t, g.base_color.truncate()) {
            bind.push((MaterialInput::BaseColor, c));
        }
        // Coverage: the factor's alpha times the texel's (glTF 3.9.4); MASK cuts at the
        // cutoff: 1 - (alpha < cutoff).
        if g.alpha_mode != AlphaMode::Opaque {
            if let Some(mut a) = b.scaled_channel("baseColorTexture", t, 3, g.base_color.w) {
                if g.alpha_mode == AlphaMode::Mask {
                    let below = b.add(
                        "alphaCutoff".into(),
                        NodeOp::Math {
                            op: MathOp::LessThan,
                            clamp: false,
                        },
                        vec![
                            a,
                            Source::Const(Vec4::splat(g.alpha_cutoff)),
                            Source::Const(Vec4::ZERO),
                        ],
                    );
                    let keep = b.add(
                        "alphaCutoff mask".into(),
                        NodeOp::Math {
                            op: MathOp::Subtract,
                            clamp: false,
                        },
                        vec![
                            Source::Const(Vec4::ONE),
                            link(below, F, F),
                            Source::Const(Vec4::ZERO),
                        ],
                    );
                    a = link(keep, F, F);
                }
                bind.push((MaterialInput::Alpha, a));
            }
        }
    }
    // One texture channel times a factor per slot (glTF 3.9.2: metallicRoughness holds the
    // roughness in green and the metalness in blue; KHR_materials_transmission: red;
    // KHR_materials_specular: the strength in alpha; KHR_materials_clearcoat: the weight in
    // red, the roughness in green; KHR_materials_sheen: the roughness in alpha).
    let coat = |t: &Option<TextureRef>| t.filter(|_| g.coat > 0.0);
    let channels = [
        (
            "metallicRoughnessTexture",
            g.metallic_roughness_texture,
            1,
            g.roughness,
            MaterialInput::Roughness,
        ),
        (
            "metallicRoughnessTexture",
            g.metallic_roughness_texture,
            2,
            g.metallic,
            MaterialInput::Metallic,
        ),
        (
            "transmissionTexture",
            g.transmission_texture,
            0,
            g.transmission,
            MaterialInput::Transmission,
        ),
        (
            "specularTexture",
            g.specular_texture,
            3,
            g.specular,
            MaterialInput::Specular,
        ),
        (
            "clearcoatTexture",
            coat(&g.coat_texture),
            0,
            g.coat,
            MaterialInput::CoatWeight,
        ),
        (
            "clearcoatRoughnessTexture",
            coat(&g.coat_roughness_texture),
            1,
            g.coat_roughness,
            MaterialInput::CoatRoughness,
        ),
        (
            "sheenRoughnessTexture",
            g.sheen_roughness_texture,
            3,
            g.sheen_roughness,
            MaterialInput::SheenRoughness,
        ),
    ];
    for (slot, texture, channel, factor, input) in channels {
        if let Some(v) = texture.and_then(|t| b.scaled_channel(slot, &t, channel, factor)) {
            bind.push((input, v));
        }
    }
    // RGB times a colour factor (emissive; KHR_materials_specular's and _sheen's colours).
    let colours = [
        (
            "emissiveTexture",
            g.emissive_texture,
            g.emissive,
            MaterialInput::Emission,
        ),
        (
            "specularColorTexture",
            g.specular_color_texture,
            g.specular_color,
            MaterialInput::SpecularTint,
        ),
        (
            "sheenColorTexture",
            g.sheen_color_texture,
            g.sheen_color,
            MaterialInput::SheenColor,
        ),
    ];
    for (slot, texture, factor, input) in colours {
        if let Some(c) = texture.and_then(|t| b.scaled_color(slot, &t, factor)) {
            bind.push((input, c));
        }
    }
    if g.iridescence > 0.0
        && (g.iridescence_texture.is_some() || g.iridescence_thickness_texture.is_some())
    {
        // KHR_materials_iridescence: the factor in red; the thickness mixes minimum and
        // maximum by green. A driven thickness makes the film; its weight and IOR come along.
        let weight = match &g.iridescence_texture {
            Some(t) => b.scaled_channel("iridescenceTexture", t, 0, g.iridescence),
            None => None,
        }
        .unwrap_or(Source::Const(Vec4::splat(g.iridescence)));
        let thickness = match &g.iridescence_thickness_texture {
            Some(t) => b.channel("iridescenceThicknessTexture", t, 1).map(|f| {
                let m = b.add(
                    "iridescenceThicknessTexture range".into(),
                    NodeOp::MixFloat { clamp_factor: true },
                    vec![
                        f,
                        Source::Const(Vec4::splat(g.iridescence_thickness_min)),
                        Source::Const(Vec4::splat(g.iridescence_thickness)),
                    ],
                );
                link(m, F, F)
            }),
            None => None,
        }
        .unwrap_or(Source::Const(Vec4::splat(g.iridescence_thickness)));
        bind.push((MaterialInput::ThinFilmWeight, weight));
        bind.push((MaterialInput::ThinFilmThickness, thickness));
        bind.push((
            MaterialInput::ThinFilmIor,
            Source::Const(Vec4::splat(g.iridescence_ior)),
        ));
    }
    (b.nodes, bind)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::image::Extension;
    use crate::shading::{ShadingGraph, ShadingInputs};

    /// 4x2 texels, each with its own value: texel (x, y) (y from the top) = (x, y, x + 4y, a).
    fn texture(wrap: [Extension; 2], bilinear: bool) -> TextureDesc {
        let texels = (0..8)
            .map(|i| {
                let (x, y) = ((i % 4) as f32, (i / 4) as f32);
                Vec4::new(x, y, x + 4.0 * y, 0.25 + 0.5 * y)
            })
            .collect();
        TextureDesc::new("t".into(), 4, 2, texels, wrap, bilinear)
    }

    /// The texel glTF's nearest lookup reads at glTF UV `uv` (origin top-left), by hand.
    fn nearest(tex: &TextureDesc, uv: Vec2) -> Vec4 {
        let axis = |t: f32, n: u32, e: Extension| -> usize {
            let i = (t * n as f32).floor() as i64;
            let n = n as i64;
            (match e {
                Extension::Repeat => i.rem_euclid(n),
                Extension::Extend => i.clamp(0, n - 1),
                Extension::Mirror => {
                    let m = i.rem_euclid(2 * n);
                    if m < n {
                        m
                    } else {
                        2 * n - 1 - m
                    }
                }
                Extension::Clip => unreachable!(),
            }) as usize
        };
        let img = &tex.image;
        let x = axis(uv.x, img.width, tex.wrap[0]);
        let y = axis(uv.y, img.height, tex.wrap[1]);
        img.texels[y * img.width as usize + x]
    }

    fn slot(texture: usize, tex_coord: u32, uv_transform: Mat3) -> TextureRef {
        TextureRef {
            texture,
            tex_coord,
            uv_transform,
        }
    }

    fn at(uv: Vec2, set: usize) -> ShadingInputs {
        let mut ctx = ShadingInputs::default();
        ctx.uv[set] = blender_uv(uv);
        ctx
    }

    #[test]
    fn slot_lookup_follows_the_gltf_convention_and_transform() {
        let tex = texture([Extension::Repeat, Extension::Mirror], false);
        // KHR_texture_transform: offset (0.3, -0.2), rotation 0.7, scale (2, 0.5).
        let (c, s) = (0.7f32.cos(), 0.7f32.sin());
        let m = Mat3::from_translation(Vec2::new(0.3, -0.2))
            * Mat3::from_cols(
                glam::Vec3::new(c, -s, 0.0),
                glam::Vec3::new(s, c, 0.0),
                glam::Vec3::Z,
            )
            * Mat3::from_scale(Vec2::new(2.0, 0.5));
        for k in 0..200 {
            let uv = Vec2::new(
                (k as f32 * 0.6180339).fract() * 3.0 - 1.0,
                (k as f32 * 0.4142135).fract() * 3.0 - 1.0,
            );
            let t = m * uv.extend(1.0);
            let want = nearest(&tex, Vec2::new(t.x, t.y));
            let got = sample_slot(&tex, &slot(0, 0, m), uv);
            // Texel edges can round either way: compare away from them.
            let f = |v: f32, n: f32| (v * n - (v * n).round()).abs();
            if f(t.x, 4.0) > 1e-3 && f(t.y, 2.0) > 1e-3 {
                assert_eq!(got, want, "uv {uv}");
            }
        }
    }

    #[test]
    fn texture_slots_bind_factor_times_channel() {
        let textures = vec![texture([Extension::Repeat; 2], false)];
        let g = GltfMaterialDesc {
            base_color: Vec4::new(0.5, 0.25, 1.0, 0.8),
            base_color_texture: Some(slot(0, 1, Mat3::IDENTITY)),
            metallic: 0.5,
            roughness: 0.75,
            metallic_roughness_texture: Some(slot(0, 0, Mat3::IDENTITY)),
            emissive: Vec3::new(2.0, 3.0, 4.0),
            emissive_texture: Some(slot(0, 0, Mat3::IDENTITY)),
            alpha_mode: AlphaMode::Mask,
            alpha_cutoff: 0.5,
            ..Default::default()
        };
        let (nodes, bindings) = texture_graph(&g, &textures);
        let graph = ShadingGraph::new(nodes, bindings);
        // TEXCOORD_0 on texel (1, 1), TEXCOORD_1 on texel (2, 0).
        let mut ctx = at(Vec2::new(0.3, 0.7), 0);
        ctx.uv[1] = blender_uv(Vec2::new(0.6, 0.2));
        let texel0 = Vec4::new(1.0, 1.0, 5.0, 0.75);
        let texel1 = Vec4::new(2.0, 0.0, 2.0, 0.25);
        let v = graph.evaluate(&ctx, false);
        let get = |m: MaterialInput| v[m.index()].unwrap();
        assert_eq!(
            get(MaterialInput::BaseColor).truncate(),
            texel1.truncate() * g.base_color.truncate()
        );
        assert_eq!(get(MaterialInput::Roughness).x, 0.75 * texel0.y);
        assert_eq!(get(MaterialInput::Metallic).x, 0.5 * texel0.z);
        let e = graph.evaluate(&ctx, true)[MaterialInput::Emission.index()].unwrap();
        assert_eq!(e.truncate(), g.emissive * texel0.truncate());
        // MASK: 0.8 x 0.25 = 0.2 is below the cutoff 0.5 -> cut out; 0.8 x 0.75 = 0.6 stays.
        assert!(graph.has_alpha());
        assert_eq!(graph.alpha(&ctx), 0.0);
        ctx.uv[1] = blender_uv(Vec2::new(0.6, 0.7));
        assert_eq!(graph.alpha(&ctx), 1.0);
    }

    #[test]
    fn sidecar_bindings_win_over_gltf_textures() {
        use crate::shading::graph::Source;
        let textures = vec![texture([Extension::Repeat; 2], false)];
        let g = GltfMaterialDesc {
            base_color_texture: Some(slot(0, 0, Mat3::IDENTITY)),
            metallic_roughness_texture: Some(slot(0, 0, Mat3::IDENTITY)),
            ..Default::default()
        };
        // A sidecar graph that drives the roughness only (a constant).
        let sidecar = ShadingGraph::new(
            vec![],
            vec![(MaterialInput::Roughness, Source::Const(Vec4::splat(0.125)))],
        );
        let (nodes, bindings) = texture_graph(&g, &textures);
        let merged = sidecar.with_fallbacks(nodes, bindings);
        let v = merged.evaluate(&at(Vec2::new(0.6, 0.2), 0), false);
        assert_eq!(v[MaterialInput::Roughness.index()].unwrap().x, 0.125);
        assert_eq!(v[MaterialInput::Metallic.index()].unwrap().x, 2.0);
        assert_eq!(
            v[MaterialInput::BaseColor.index()].unwrap().truncate(),
            Vec3::new(2.0, 0.0, 2.0)
        );
    }

    /// The graph's UV Map -> transform -> Image Texture chain reads what `sample_slot` reads.
    #[test]
    fn graph_lookup_equals_the_slot_lookup() {
        let textures = vec![texture([Extension::Mirror, Extension::Extend], true)];
        let m = Mat3::from_translation(Vec2::new(-0.4, 0.15)) * Mat3::from_angle(0.3);
        let t = slot(0, 0, m);
        let g = GltfMaterialDesc {
            base_color_texture: Some(t),
            ..Default::default()
        };
        let (nodes, bindings) = texture_graph(&g, &textures);
        let graph = ShadingGraph::new(nodes, bindings);
        for k in 0..100 {
            let uv = Vec2::new(
                (k as f32 * 0.7548776).fract() * 4.0 - 2.0,
                (k as f32 * 0.5698403).fract() * 4.0 - 2.0,
            );
            let v = graph.evaluate(&at(uv, 0), false)[MaterialInput::BaseColor.index()].unwrap();
            let want = sample_slot(&textures[0], &t, uv);
            assert!(
                (v.truncate() - want.truncate()).abs().max_element() < 1e-5,
                "uv {uv}: {v} vs {want}"
            );
        }
    }
}
