use crate::error::{PrismError, Result};
use std::path::Path;

/// Writes float32 RGBA (row 0 = top). Values are assumed finite (the film guarantees it).
pub fn write_exr_rgba(path: &Path, width: u32, height: u32, rgba: &[[f32; 4]]) -> Result<()> {
    let w = width as usize;
    exr::prelude::write_rgba_file(path, w, height as usize, |x, y| {
        let p = rgba[y * w + x];
        (p[0], p[1], p[2], p[3])
    })
    .map_err(|e| PrismError::internal(format!("{}: cannot write EXR: {e}", path.display())))
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
