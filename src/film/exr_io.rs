use crate::error::{PrismError, Result};
use std::path::Path;

/// How EXR files are compressed: all three are lossless on float32 data, and every reader
/// (Blender, the add-on's numpy reader, `exr`) reads all three.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExrCompression {
    /// Run-length encoding in 64x64 tiles (the default): fast, compresses flat regions.
    #[default]
    Rle,
    /// ZIP over 16 scanlines: the smallest files, the slowest to write.
    Zip,
    /// Raw scanlines: the fastest to write and read (the Blender add-on's temporary files,
    /// which numpy reads at memory speed).
    None,
}

impl ExrCompression {
    fn encoding(self) -> exr::prelude::Encoding {
        use exr::prelude::Encoding;
        match self {
            ExrCompression::Rle => Encoding::FAST_LOSSLESS,
            ExrCompression::Zip => Encoding::SMALL_LOSSLESS,
            ExrCompression::None => Encoding::UNCOMPRESSED,
        }
    }
}

/// Writes float32 RGBA (row 0 = top), RLE-compressed. Values are assumed finite (the film
/// guarantees it).
pub fn write_exr_rgba(path: &Path, width: u32, height: u32, rgba: &[[f32; 4]]) -> Result<()> {
    write_exr_rgba_with(path, width, height, rgba, ExrCompression::Rle)
}

/// [`write_exr_rgba`] with a choice of compression.
pub fn write_exr_rgba_with(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[[f32; 4]],
    compression: ExrCompression,
) -> Result<()> {
    use exr::prelude::*;
    let w = width as usize;
    let layer = Layer::new(
        (w, height as usize),
        LayerAttributes::default(),
        compression.encoding(),
        SpecificChannels::rgba(|p: Vec2<usize>| {
            let q = rgba[p.y() * w + p.x()];
            (q[0], q[1], q[2], q[3])
        }),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| PrismError::internal(format!("{}: cannot write EXR: {e}", path.display())))
}

/// Writes float32 channels of one layer (names like "R", "Albedo.R", "Depth.Z"; row 0 = top).
pub fn write_exr_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<(&str, Vec<f32>)>,
    compression: ExrCompression,
) -> Result<()> {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name, FlatSamples::F32(data)))
        .collect();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        compression.encoding(),
        AnyChannels::sort(list),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| PrismError::internal(format!("{}: cannot write EXR: {e}", path.display())))
}

/// Reads one float channel by name from the first layer (row 0 = top): (width, height, data).
pub fn read_exr_channel(path: &Path, name: &str) -> Result<(u32, u32, Vec<f32>)> {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path)
        .map_err(|e| PrismError::input(format!("{}: cannot read EXR: {e}", path.display())))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| PrismError::input(format!("{}: EXR has no layer", path.display())))?;
    let size = layer.size;
    let channel = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .ok_or_else(|| {
            PrismError::input(format!("{}: EXR has no channel '{name}'", path.display()))
        })?;
    let data = channel.sample_data.values_as_f32().collect();
    Ok((size.width() as u32, size.height() as u32, data))
}

/// Reads the first RGBA layer of an EXR as float32 (row 0 = top): (width, height, pixels).
pub fn read_exr_rgba(path: &Path) -> Result<(u32, u32, Vec<[f32; 4]>)> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0f32; 4]; res.width() * res.height()]),
        |(w, px), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b, a]
        },
    )
    .map_err(|e| PrismError::input(format!("{}: cannot read EXR: {e}", path.display())))?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    Ok((size.width() as u32, size.height() as u32, pixels))
}
