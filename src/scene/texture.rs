//! Texture helpers for the scene loaders: decoding encoded images (PNG/JPEG) into linear texels,
//! `data:` URIs, base64 and percent-decoding of glTF URIs. Lookups are the shading graph's Image
//! Texture node (`scene::gltf_graph`).

use glam::Vec4;

use crate::scene::desc::ColorSpace;
use crate::spectrum::rgb::srgb_to_linear;

/// An image decoded to normalised RGBA in [0,1], still encoded (sRGB or linear as stored).
#[derive(Clone, Debug)]
pub struct DecodedImage {
    pub width: u32,
    pub height: u32,
    /// Row 0 = top row of the image.
    pub rgba: Vec<[f32; 4]>,
    /// Stored with 8 bits per channel (Cycles filters those before decoding sRGB).
    pub eight_bit: bool,
}

/// Decodes PNG/JPEG bytes. `mime` is only a hint; the format is sniffed from the content.
pub fn decode_image(bytes: &[u8], mime: Option<&str>) -> Result<DecodedImage, String> {
    let guessed = image::guess_format(bytes).ok();
    let format = match guessed {
        Some(f) => f,
        None => match mime {
            Some("image/png") => image::ImageFormat::Png,
            Some("image/jpeg") => image::ImageFormat::Jpeg,
            Some("image/webp") => image::ImageFormat::WebP,
            Some(m) => {
                return Err(format!(
                    "unsupported image type '{m}' (PNG, JPEG and WebP are)"
                ))
            }
            None => {
                return Err("unrecognised image format (PNG, JPEG and WebP are supported)".into())
            }
        },
    };
    // WebP arrives through EXT_texture_webp (glTF textures are PNG or JPEG otherwise).
    if !matches!(
        format,
        image::ImageFormat::Png | image::ImageFormat::Jpeg | image::ImageFormat::WebP
    ) {
        return Err(format!(
            "unsupported image format {format:?} (PNG, JPEG and WebP are supported)"
        ));
    }
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    // The default limits (512 MiB allocations) stay in force against decompression bombs.
    reader.limits(image::Limits::default());
    let img = reader
        .decode()
        .map_err(|e| format!("cannot decode image: {e}"))?;
    let (width, height) = (img.width(), img.height());
    let eight_bit = img.color().bytes_per_pixel() == img.color().channel_count();
    if width == 0 || height == 0 {
        return Err("image has zero size".into());
    }
    let rgba = img.to_rgba32f();
    let rgba = rgba
        .pixels()
        .map(|p| [p.0[0], p.0[1], p.0[2], p.0[3]])
        .collect();
    Ok(DecodedImage {
        width,
        height,
        rgba,
        eight_bit,
    })
}

/// Linear texels for a decoded image: sRGB colour spaces decode RGB through the sRGB EOTF, alpha
/// always stays linear.
pub fn to_linear_texels(img: &DecodedImage, space: ColorSpace) -> Vec<Vec4> {
    img.rgba
        .iter()
        .map(|p| match space {
            ColorSpace::Srgb => Vec4::new(
                srgb_to_linear(p[0]),
                srgb_to_linear(p[1]),
                srgb_to_linear(p[2]),
                p[3],
            ),
            ColorSpace::Linear => Vec4::from_array(*p),
        })
        .collect()
}

/// Standard base64 (RFC 4648) decoding, padding optional, ASCII whitespace ignored.
pub fn base64_decode(s: &str) -> Result<Vec<u8>, String> {
    fn val(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some((c - b'A') as u32),
            b'a'..=b'z' => Some((c - b'a') as u32 + 26),
            b'0'..=b'9' => Some((c - b'0') as u32 + 52),
            b'+' | b'-' => Some(62),
            b'/' | b'_' => Some(63),
            _ => None,
        }
    }
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let mut acc = 0u32;
    let mut bits = 0u32;
    let mut seen_pad = false;
    for (i, &c) in s.as_bytes().iter().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            seen_pad = true;
            continue;
        }
        if seen_pad {
            return Err(format!("invalid base64: data after padding at offset {i}"));
        }
        let v = val(c).ok_or_else(|| {
            format!(
                "invalid base64: unexpected character {:?} at offset {i}",
                c as char
            )
        })?;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("invalid base64: truncated data".into());
    }
    Ok(out)
}

/// A parsed `data:` URI: its media type (if given) and decoded bytes.
pub struct DataUri {
    pub mime: Option<String>,
    pub bytes: Vec<u8>,
}

/// Parses `data:[<mediatype>][;base64],<data>`. Returns `None` when `uri` is not a data URI.
pub fn parse_data_uri(uri: &str) -> Option<Result<DataUri, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, data)) = rest.split_once(',') else {
        return Some(Err("malformed data URI (no ',')".into()));
    };
    let mut parts = header.split(';');
    let mime = parts.next().filter(|m| !m.is_empty()).map(str::to_owned);
    let is_base64 = parts.any(|p| p.eq_ignore_ascii_case("base64"));
    let bytes = if is_base64 {
        match base64_decode(data) {
            Ok(b) => b,
            Err(e) => return Some(Err(format!("data URI: {e}"))),
        }
    } else {
        percent_decode(data)
    };
    Some(Ok(DataUri { mime, bytes }))
}

/// Decodes `%XX` escapes of a relative URI (glTF URIs are RFC 3986). Invalid escapes stay as is.
pub fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_roundtrip_known_vectors() {
        assert_eq!(base64_decode("").unwrap(), b"");
        assert_eq!(base64_decode("Zg==").unwrap(), b"f");
        assert_eq!(base64_decode("Zm8=").unwrap(), b"fo");
        assert_eq!(base64_decode("Zm9v").unwrap(), b"foo");
        assert_eq!(base64_decode("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(base64_decode("Zm9vYg").unwrap(), b"foob");
        assert!(base64_decode("Zm9v!").is_err());
        assert!(base64_decode("Z").is_err());
    }

    #[test]
    fn data_uri_and_percent() {
        let d = parse_data_uri("data:application/octet-stream;base64,Zm9v")
            .unwrap()
            .unwrap();
        assert_eq!(d.bytes, b"foo");
        assert_eq!(d.mime.as_deref(), Some("application/octet-stream"));
        assert!(parse_data_uri("x.bin").is_none());
        assert_eq!(percent_decode("a%20b.bin"), b"a b.bin");
        assert_eq!(percent_decode("a%2"), b"a%2");
        assert_eq!(percent_decode("%"), b"%");
    }
}
