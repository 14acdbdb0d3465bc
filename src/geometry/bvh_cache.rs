//! An on-disk cache of mesh BVHs, so re-rendering an unchanged mesh (the usual F12 loop in
//! Blender, or the frames of an animation where only lights or materials move) skips the
//! build: for 100k triangles the build is 55-75 ms of the Blender round trip, for a million
//! triangles most of a second. The same idea as Cycles' "persistent data", across processes.
//!
//! Opt-in: nothing is read or written unless a directory is set ([`set_cache_dir`], the CLI's
//! `--bvh-cache DIR`). An entry is keyed by a 64-bit hash of exactly the data the BVH is built
//! from (the triangles in object space, in order) plus the build preset and this format's
//! version, and stores that triangle count and a checksum of its payload: any mismatch,
//! truncation or corruption makes the entry a miss (the BVH is built and the entry rewritten),
//! never a wrong or crashing traversal. Writes go to a temporary name and are renamed, so
//! concurrent renders never read half an entry. The directory is pruned to [`MAX_CACHE_BYTES`],
//! oldest entries first.

use std::hash::Hasher;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Mutex, OnceLock};
use std::thread::JoinHandle;

use obvhs::aabb::Aabb;
use obvhs::cwbvh::{node::CwBvhNode, CwBvh};

const MAGIC: &[u8; 8] = b"PRSMBVH1";
/// Bump when the layout or obvhs' node format changes.
const FORMAT_VERSION: u32 = 1;
/// Cache size bound: entries are ~45 bytes per triangle, so this holds ~20M triangles.
pub const MAX_CACHE_BYTES: u64 = 1 << 30;

static CACHE_DIR: OnceLock<PathBuf> = OnceLock::new();
static HITS: AtomicUsize = AtomicUsize::new(0);
static MISSES: AtomicUsize = AtomicUsize::new(0);
/// The background writer: a cold render starts path tracing while its new entries are
/// encoded, written and the directory pruned (a few ms per 100k triangles, longer on a slow
/// disk or a large cache directory), instead of waiting for the disk. One thread, fed in
/// order, however many meshes the scene has.
static WRITER: Mutex<Option<Writer>> = Mutex::new(None);

struct Writer {
    queue: Sender<(u64, usize, CwBvh)>,
    thread: JoinHandle<()>,
}

/// (hits, misses) of this process so far (misses: lookups that had to build).
pub fn counters() -> (usize, usize) {
    (HITS.load(Ordering::Relaxed), MISSES.load(Ordering::Relaxed))
}

/// Enables the cache for this process (first call wins). Creates the directory.
pub fn set_cache_dir(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let _ = CACHE_DIR.set(dir.to_path_buf());
    Ok(())
}

fn cache_dir() -> Option<&'static Path> {
    CACHE_DIR.get().map(PathBuf::as_path)
}

/// Whether [`set_cache_dir`] has enabled the cache.
pub fn enabled() -> bool {
    CACHE_DIR.get().is_some()
}

/// 64-bit SipHash-2-4 of the parts (std's, fixed keys: stable across runs and builds).
fn hash_bytes(parts: &[&[u8]]) -> u64 {
    #[allow(deprecated)]
    let mut h = std::hash::SipHasher::new_with_keys(0x5052_4953, 0x4d42_5648);
    for p in parts {
        h.write_usize(p.len());
        h.write(p);
    }
    h.finish()
}

fn entry_path(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.bvh"))
}

/// The key of a BVH built with preset `preset` from the data in `parts` (raw bytes that
/// determine the triangles, e.g. a mesh's positions and indices; native byte order is fine,
/// the cache lives on one machine).
pub fn key(parts: &[&[u8]], preset: u8) -> u64 {
    let mut all = parts.to_vec();
    let preset = [preset];
    let version = FORMAT_VERSION.to_le_bytes();
    all.extend([&preset[..], &version[..]]);
    hash_bytes(&all)
}

/// The cached BVH for `key` over `triangles` triangles, if the cache is on and holds a valid
/// entry.
pub fn load(key: u64, triangles: usize) -> Option<CwBvh> {
    let dir = cache_dir()?;
    let found = std::fs::read(entry_path(dir, key))
        .ok()
        .and_then(|bytes| decode(&bytes, key, triangles));
    let counter = if found.is_some() { &HITS } else { &MISSES };
    counter.fetch_add(1, Ordering::Relaxed);
    found
}

/// Stores `bvh` under `key` in the background (best effort: a full disk or a read-only
/// directory only costs the next render a rebuild); see [`wait_for_stores`].
pub fn store(key: u64, triangles: usize, bvh: &CwBvh) {
    let Some(dir) = cache_dir() else {
        return;
    };
    let mut writer = WRITER.lock().unwrap_or_else(|e| e.into_inner());
    let writer = writer.get_or_insert_with(|| {
        let (queue, entries) = std::sync::mpsc::channel::<(u64, usize, CwBvh)>();
        let thread = std::thread::spawn(move || {
            for (key, triangles, bvh) in entries {
                write_entry(dir, key, triangles, &bvh);
            }
        });
        Writer { queue, thread }
    });
    // A send fails only if the writer thread died (it panicked); the entry is then skipped.
    let _ = writer.queue.send((key, triangles, bvh.clone()));
}

/// Waits for the entries [`store`] has queued to be written. The binary calls it before it
/// exits, so a process end never cuts a write short (which would only leave a stray temporary
/// file: entries appear by rename). Library users who need an entry on disk call it too.
pub fn wait_for_stores() {
    let writer = WRITER.lock().unwrap_or_else(|e| e.into_inner()).take();
    if let Some(Writer { queue, thread }) = writer {
        drop(queue); // ends the writer's loop once the queue is empty
        let _ = thread.join();
    }
}

fn write_entry(dir: &Path, key: u64, triangles: usize, bvh: &CwBvh) {
    let bytes = encode(bvh, key, triangles);
    let path = entry_path(dir, key);
    let tmp = dir.join(format!(".{key:016x}.{}.partial", std::process::id()));
    if std::fs::write(&tmp, &bytes).is_ok() && std::fs::rename(&tmp, &path).is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    prune(dir, MAX_CACHE_BYTES);
}

/// Removes the least recently modified entries until the directory's entries fit in `limit`.
fn prune(dir: &Path, limit: u64) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut files: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "bvh"))
        .filter_map(|e| {
            let m = e.metadata().ok()?;
            Some((m.modified().ok()?, m.len(), e.path()))
        })
        .collect();
    let mut total: u64 = files.iter().map(|f| f.1).sum();
    files.sort();
    for (_, len, path) in files {
        if total <= limit {
            break;
        }
        if std::fs::remove_file(&path).is_ok() {
            total -= len;
        }
    }
}

// Layout: MAGIC, version u32, key u64, triangles u64, nodes u64, primitive indices u64,
// exact aabbs u64 (0 = none), spatial splits u8, total_aabb (2 x 4 f32), then the node,
// index and aabb arrays as raw little-endian data, then the SipHash of everything before it.

fn encode(bvh: &CwBvh, key: u64, triangles: usize) -> Vec<u8> {
    let nodes: &[u8] = bytemuck::cast_slice(&bvh.nodes);
    let indices: &[u8] = bytemuck::cast_slice(&bvh.primitive_indices);
    let exact: &[u8] = bvh
        .exact_node_aabbs
        .as_deref()
        .map(bytemuck::cast_slice)
        .unwrap_or(&[]);
    let mut out = Vec::with_capacity(96 + nodes.len() + indices.len() + exact.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
    for n in [
        triangles,
        bvh.nodes.len(),
        bvh.primitive_indices.len(),
        bvh.exact_node_aabbs.as_ref().map_or(0, Vec::len),
    ] {
        out.extend_from_slice(&(n as u64).to_le_bytes());
    }
    out.push(bvh.uses_spatial_splits as u8);
    out.extend_from_slice(bytemuck::bytes_of(&bvh.total_aabb));
    out.extend_from_slice(nodes);
    out.extend_from_slice(indices);
    out.extend_from_slice(exact);
    let checksum = hash_bytes(&[&out]);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

fn decode(bytes: &[u8], key: u64, triangles: usize) -> Option<CwBvh> {
    let (body, tail) = bytes.split_at(bytes.len().checked_sub(8)?);
    if hash_bytes(&[body]).to_le_bytes() != *tail {
        return None;
    }
    let mut rest = body.strip_prefix(MAGIC.as_slice())?;
    let mut take = |n: usize| -> Option<&[u8]> {
        if rest.len() < n {
            return None;
        }
        let (a, b) = rest.split_at(n);
        rest = b;
        Some(a)
    };
    let u32_at = |b: &[u8]| u32::from_le_bytes(b.try_into().unwrap_or_default());
    let u64_at = |b: &[u8]| u64::from_le_bytes(b.try_into().unwrap_or_default());
    if u32_at(take(4)?) != FORMAT_VERSION || u64_at(take(8)?) != key {
        return None;
    }
    let mut counts = [0usize; 4];
    for c in &mut counts {
        *c = usize::try_from(u64_at(take(8)?)).ok()?;
    }
    let [tri_count, node_count, index_count, exact_count] = counts;
    if tri_count != triangles || index_count != triangles || node_count == 0 {
        return None;
    }
    let uses_spatial_splits = take(1)?[0] != 0;
    let total_aabb: Aabb = bytemuck::pod_read_unaligned(take(std::mem::size_of::<Aabb>())?);
    let nodes: Vec<CwBvhNode> = pod_vec(take(
        node_count.checked_mul(std::mem::size_of::<CwBvhNode>())?,
    )?);
    let primitive_indices: Vec<u32> = pod_vec(take(index_count.checked_mul(4)?)?);
    let exact: Vec<Aabb> = pod_vec(take(exact_count.checked_mul(std::mem::size_of::<Aabb>())?)?);
    if !rest.is_empty() {
        return None;
    }
    // Indices must address the triangles (the checksum already rules out corruption; this
    // also guards against a hash collision of the key sending another mesh's BVH here).
    if primitive_indices.iter().any(|&i| i as usize >= triangles) {
        return None;
    }
    Some(CwBvh {
        nodes,
        primitive_indices,
        total_aabb,
        exact_node_aabbs: (exact_count > 0).then_some(exact),
        uses_spatial_splits,
    })
}

/// Copies raw bytes into a vector of `T` (the file's data has no alignment guarantee).
fn pod_vec<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    bytes
        .chunks_exact(std::mem::size_of::<T>())
        .map(bytemuck::pod_read_unaligned)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrupt_or_mismatched_entries_are_misses() {
        let bvh = CwBvh {
            nodes: vec![CwBvhNode::default(); 3],
            primitive_indices: vec![0, 1],
            total_aabb: Aabb::empty(),
            exact_node_aabbs: None,
            uses_spatial_splits: false,
        };
        let bytes = encode(&bvh, 42, 2);
        let back = decode(&bytes, 42, 2).expect("round trip");
        assert_eq!(back.nodes.len(), 3);
        assert_eq!(back.primitive_indices, vec![0, 1]);
        assert!(decode(&bytes, 43, 2).is_none(), "other key");
        assert!(decode(&bytes, 42, 3).is_none(), "other triangle count");
        for cut in [0, 1, 8, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut], 42, 2).is_none(), "truncated at {cut}");
        }
        for flip in [0, 9, 30, bytes.len() / 2, bytes.len() - 9] {
            let mut bad = bytes.clone();
            bad[flip] ^= 0x40;
            assert!(decode(&bad, 42, 2).is_none(), "bit flipped at {flip}");
        }
    }
}
