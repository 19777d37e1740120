//! The file around the scene: a GLB container (header, JSON chunk, BIN chunk) or plain JSON,
//! the JSON parsed into the `gltf` crate's types (without its validation), and the buffers
//! (the GLB's BIN chunk, base64 `data:` URIs, files relative to the scene).

use super::Ctx;
use crate::error::Result;
use gltf::json::Root;
use std::path::Path;

/// The parsed document with its buffers' bytes, `buffers[i]` for `/buffers/i`.
pub(crate) struct Document {
    pub root: Root,
    pub buffers: Vec<Vec<u8>>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Parse a `.glb` (by its magic or its extension) or a `.gltf` JSON text, and load its buffers.
pub(crate) fn parse(cx: &Ctx, bytes: &[u8], base: &Path) -> Result<Document> {
    let glb_name = Path::new(cx.file).extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let (json, bin) = if bytes.starts_with(GLB_MAGIC) || glb_name { split_glb(cx, bytes)? } else { (bytes, None) };
    let root = parse_json(cx, json)?;
    let buffers = load_buffers(cx, &root, bin, base)?;
    Ok(Document { root, buffers })
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// The JSON chunk and the BIN chunk (if any) of a GLB file.
fn split_glb<'a>(cx: &Ctx, b: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>)> {
    let bad = |m: String| cx.err("", format!("not a valid GLB file: {m}"));
    if !b.starts_with(GLB_MAGIC) {
        let magic = &b[..b.len().min(4)];
        return Err(bad(format!("its first bytes are {magic:?}, not \"glTF\"")));
    }
    let version = u32_at(b, 4).ok_or_else(|| bad("truncated header (12 bytes expected)".into()))?;
    let length = u32_at(b, 8).ok_or_else(|| bad("truncated header (12 bytes expected)".into()))? as usize;
    if version != 2 {
        return Err(bad(format!("version {version} (this program reads glTF 2)")));
    }
    if length > b.len() {
        return Err(bad(format!("the header declares {length} bytes, the file has {}", b.len())));
    }
    let b = &b[..length];
    let (json, next) = chunk(b, 12).map_err(&bad)?;
    if json.0 != CHUNK_JSON {
        return Err(bad("the first chunk is not JSON".into()));
    }
    if next >= b.len() {
        return Ok((json.1, None));
    }
    let (bin, _) = chunk(b, next).map_err(&bad)?;
    if bin.0 != CHUNK_BIN {
        return Err(bad(format!("the second chunk has type {:#010x}, not BIN", bin.0)));
    }
    Ok((json.1, Some(bin.1)))
}

/// The chunk at `at`: (type, data) and where the next chunk starts.
fn chunk(b: &[u8], at: usize) -> std::result::Result<((u32, &[u8]), usize), String> {
    let len = u32_at(b, at).ok_or_else(|| format!("truncated chunk header at byte {at}"))? as usize;
    let ty = u32_at(b, at + 4).ok_or_else(|| format!("truncated chunk header at byte {at}"))?;
    let start = at + 8;
    let end = start.checked_add(len).filter(|&e| e <= b.len()).ok_or_else(|| {
        format!("the chunk at byte {at} declares {len} bytes, {} remain", b.len().saturating_sub(start))
    })?;
    Ok(((ty, &b[start..end]), end))
}

/// The JSON parsed into `gltf::json::Root`; a type error names its JSON pointer.
fn parse_json(cx: &Ctx, json: &[u8]) -> Result<Root> {
    let de = &mut serde_json::Deserializer::from_slice(json);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let pointer = pointer_of(e.path());
        let inner = e.into_inner();
        let mut message = inner.to_string();
        if let Some(i) = message.rfind(" at line ") {
            message.truncate(i);
        }
        let mut err = cx.err(pointer, format!("not valid glTF JSON: {message}"));
        if let crate::Error::Input { line, .. } = &mut err
            && inner.line() > 0
        {
            *line = Some((inner.line(), inner.column()));
        }
        err
    })
}

/// `meshes[3].primitives[0]` as the JSON pointer `/meshes/3/primitives/0`.
fn pointer_of(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut s = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => s += &format!("/{index}"),
            Segment::Map { key } => s += &format!("/{}", key.replace('~', "~0").replace('/', "~1")),
            Segment::Enum { variant } => s += &format!("/{variant}"),
            Segment::Unknown => s += "/?",
        }
    }
    s
}

/// Every buffer's bytes, at least `byteLength` of them (more is allowed: GLB padding).
fn load_buffers(cx: &Ctx, root: &Root, bin: Option<&[u8]>, base: &Path) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::with_capacity(root.buffers.len());
    for (i, b) in root.buffers.iter().enumerate() {
        let at = format!("/buffers/{i}");
        let data = match &b.uri {
            None if i == 0 => bin.ok_or_else(|| cx.err(&at, "has no uri and the file has no GLB BIN chunk"))?.to_vec(),
            None => return Err(cx.err(&at, "has no uri (only buffer 0 may be a GLB's BIN chunk)")),
            Some(uri) if uri.starts_with("data:") => {
                decode_data_uri(uri).map_err(|m| cx.err(format!("{at}/uri"), m))?
            }
            Some(uri) => read_relative(base, uri).map_err(|m| cx.err(format!("{at}/uri"), m))?,
        };
        let declared = b.byte_length.0;
        if (data.len() as u64) < declared {
            return Err(
                cx.err(format!("{at}/byteLength"), format!("declares {declared} bytes, the buffer has {}", data.len()))
            );
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of a `data:[<mime>];base64,<data>` URI.
fn decode_data_uri(uri: &str) -> std::result::Result<Vec<u8>, String> {
    let (head, data) = uri.split_once(',').ok_or("a data: URI without a comma")?;
    if !head.ends_with(";base64") {
        return Err("only base64 data: URIs are read".into());
    }
    base64_decode(data)
}

/// Standard base64 (RFC 4648, with or without padding).
pub(crate) fn base64_decode(s: &str) -> std::result::Result<Vec<u8>, String> {
    use base64::Engine;
    use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
    const ENGINE: GeneralPurpose = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
    );
    ENGINE.decode(s).map_err(|e| format!("bad base64 data: {e}"))
}

/// A buffer file named by a relative URI (percent-escapes decoded).
fn read_relative(base: &Path, uri: &str) -> std::result::Result<Vec<u8>, String> {
    if uri.contains("://") || uri.starts_with('/') {
        return Err(format!("\"{uri}\": only relative file URIs and data: URIs are read"));
    }
    let decoded =
        percent_decode(uri).ok_or_else(|| format!("\"{uri}\": percent-escapes that do not decode to UTF-8"))?;
    let full = base.join(&decoded);
    std::fs::read(&full).map_err(|e| format!("cannot read {}: {e}", full.display()))
}

/// A URI's percent-escapes decoded (`None`: not UTF-8 then).
fn percent_decode(s: &str) -> Option<String> {
    percent_encoding::percent_decode_str(s).decode_utf8().ok().map(|c| c.into_owned())
}
