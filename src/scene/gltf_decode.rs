//! Compressed glTF geometry, decoded before `gltf_io` reads it:
//!
//! - `KHR_draco_mesh_compression`: a primitive whose POSITION, NORMAL and indices live in
//!   one Draco stream (a buffer view); decoded with `draco-core`, a pure-Rust decoder of
//!   the reference bitstream, with its output ceilings set to the primitive's declared
//!   counts so a stream cannot claim more than the file admitted to before buffers load.
//! - `EXT_meshopt_compression`: buffer views whose bytes are a meshoptimizer stream
//!   (`ATTRIBUTES`, `TRIANGLES` or `INDICES`, with the `OCTAHEDRAL`, `QUATERNION` or
//!   `EXPONENTIAL` filter); decoded with the `meshopt` crate (meshoptimizer's own C++
//!   decoders) into the view's place in its buffer, which is then read like any other.
//!   A fallback buffer without a URI is allocated zeroed for them.
//! - `KHR_mesh_quantization`: POSITION as (normalized or plain) 8/16-bit integers and
//!   NORMAL as normalized 8/16-bit integers, widened to float here (`read_vec3`). The
//!   dequantizing scale and offset are on the node, so the world transform applies them.

use anyhow::{anyhow, bail, Result};
use glam::Vec3;
use serde_json::Value;
use std::collections::HashMap;

/// Required extensions this module decodes: `gltf_io` accepts them.
pub const DECODED_EXTENSIONS: &[&str] = &[
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
];

const DRACO: &str = "KHR_draco_mesh_compression";
const MESHOPT: &str = "EXT_meshopt_compression";

/// A Draco-compressed primitive: the view holding its stream and the stream's attribute
/// ids for POSITION and NORMAL.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Draco {
    pub view: usize,
    /// The view's buffer, offset and length.
    pub stream: (usize, usize, usize),
    pub position: u32,
    pub normal: Option<u32>,
}

/// A meshopt-compressed buffer view.
#[derive(Debug)]
struct Meshopt {
    view: usize,
    /// Where the stream is: buffer, offset, length.
    source: (usize, usize, usize),
    /// Where the decoded bytes go: buffer, offset (`count * stride` bytes).
    target: (usize, usize),
    stride: usize,
    count: usize,
    mode: String,
    filter: String,
}

/// What a file compresses, read from its JSON before its buffers are loaded.
#[derive(Debug, Default)]
pub struct Compressed {
    draco: HashMap<(usize, usize), Draco>,
    meshopt: Vec<Meshopt>,
    /// Buffers that only stand in for decoded meshopt data (`fallback: true`, no URI).
    fallback: Vec<usize>,
}

fn ext<'a>(others: Option<&'a serde_json::Map<String, Value>>, name: &str) -> Option<&'a Value> {
    others.and_then(|m| m.get(name))
}

fn uint(v: &Value, key: &str, what: &str) -> Result<Option<usize>> {
    match v.get(key) {
        None => Ok(None),
        Some(x) => x
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .map(Some)
            .ok_or_else(|| anyhow!("{what}: '{key}' must be a non-negative integer, not {x}")),
    }
}

fn need(v: &Value, key: &str, what: &str) -> Result<usize> {
    uint(v, key, what)?.ok_or_else(|| anyhow!("{what}: has no '{key}'"))
}

impl Compressed {
    /// Reads the Draco primitives, meshopt views and fallback buffers of `root`.
    pub fn scan(root: &gltf::json::Root, file: &str) -> Result<Self> {
        let mut out = Compressed::default();
        for (m, mesh) in root.meshes.iter().enumerate() {
            for (p, prim) in mesh.primitives.iter().enumerate() {
                let Some(d) = ext(prim.extensions.as_ref().map(|e| &e.others), DRACO) else {
                    continue;
                };
                let what = format!("{file}: mesh {m}, primitive {p}: {DRACO}");
                let view = need(d, "bufferView", &what)?;
                let v = root
                    .buffer_views
                    .get(view)
                    .ok_or_else(|| anyhow!("{what}: bufferView {view} does not exist"))?;
                let stream = (
                    v.buffer.value(),
                    v.byte_offset.map_or(0, |o| o.0 as usize),
                    v.byte_length.0 as usize,
                );
                let attrs = d
                    .get("attributes")
                    .ok_or_else(|| anyhow!("{what}: has no 'attributes'"))?;
                let id = |name: &str| -> Result<Option<u32>> {
                    uint(attrs, name, &what)?
                        .map(|n| {
                            u32::try_from(n)
                                .map_err(|_| anyhow!("{what}: {name} id {n} is too large"))
                        })
                        .transpose()
                };
                let position =
                    id("POSITION")?.ok_or_else(|| anyhow!("{what}: has no POSITION attribute"))?;
                out.draco.insert(
                    (m, p),
                    Draco {
                        view,
                        stream,
                        position,
                        normal: id("NORMAL")?,
                    },
                );
            }
        }
        for (k, view) in root.buffer_views.iter().enumerate() {
            let Some(e) = ext(view.extensions.as_ref().map(|e| &e.others), MESHOPT) else {
                continue;
            };
            let what = format!("{file}: buffer view {k}: {MESHOPT}");
            let text = |key: &str, default: &str| -> Result<String> {
                match e.get(key) {
                    None => Ok(default.to_owned()),
                    Some(Value::String(s)) => Ok(s.clone()),
                    Some(x) => bail!("{what}: '{key}' must be a string, not {x}"),
                }
            };
            out.meshopt.push(Meshopt {
                view: k,
                source: (
                    need(e, "buffer", &what)?,
                    uint(e, "byteOffset", &what)?.unwrap_or(0),
                    need(e, "byteLength", &what)?,
                ),
                target: (
                    view.buffer.value(),
                    view.byte_offset.map_or(0, |o| o.0 as usize),
                ),
                stride: need(e, "byteStride", &what)?,
                count: need(e, "count", &what)?,
                mode: text("mode", "")?,
                filter: text("filter", "NONE")?,
            });
            let m = out.meshopt.last().expect("just pushed");
            let decoded = m.count.checked_mul(m.stride);
            if decoded.is_none_or(|n| n > view.byte_length.0 as usize) {
                bail!(
                    "{what}: {} elements of {} bytes do not fit the view's byteLength {}",
                    m.count,
                    m.stride,
                    view.byte_length.0
                );
            }
        }
        for (b, buffer) in root.buffers.iter().enumerate() {
            let fallback = ext(buffer.extensions.as_ref().map(|e| &e.others), MESHOPT)
                .and_then(|e| e.get("fallback"))
                .and_then(Value::as_bool)
                == Some(true);
            if fallback && buffer.uri.is_none() {
                out.fallback.push(b);
            }
        }
        Ok(out)
    }

    /// Points the Draco primitives' accessors that have no buffer view (their data is in
    /// the stream) at the stream's view, so that the `gltf` crate's validation, which asks
    /// every non-sparse accessor for one, passes. Those accessors are never read: a Draco
    /// primitive is read from its stream alone.
    pub fn stand_in_views(&self, root: &mut gltf::json::Root) {
        for (&(m, p), d) in &self.draco {
            let Some(prim) = root.meshes.get(m).and_then(|mesh| mesh.primitives.get(p)) else {
                continue;
            };
            let used: Vec<usize> = prim
                .attributes
                .values()
                .chain(prim.indices.as_ref())
                .map(|i| i.value())
                .collect();
            for a in used {
                if let Some(acc) = root.accessors.get_mut(a) {
                    if acc.buffer_view.is_none() && acc.sparse.is_none() {
                        acc.buffer_view = Some(gltf::json::Index::new(d.view as u32));
                    }
                }
            }
        }
    }

    /// The Draco stream of primitive `prim` of mesh `mesh`, if it has one.
    pub fn draco(&self, mesh: usize, prim: usize) -> Option<Draco> {
        self.draco.get(&(mesh, prim)).copied()
    }

    /// Whether buffer `b` only stands in for decoded data (no bytes of its own).
    pub fn is_fallback(&self, b: usize) -> bool {
        self.fallback.contains(&b)
    }

    /// Decodes every meshopt view into its place in `buffers`.
    pub fn decode_meshopt(&self, buffers: &mut [Vec<u8>], file: &str) -> Result<()> {
        for m in &self.meshopt {
            let what = format!("{file}: buffer view {}: {MESHOPT}", m.view);
            let (sb, so, sl) = m.source;
            let src = buffers
                .get(sb)
                .and_then(|b| b.get(so..so.checked_add(sl)?))
                .ok_or_else(|| anyhow!("{what}: its stream reaches past the end of buffer {sb}"))?
                .to_vec();
            let bytes = decode_stream(&src, m).map_err(|e| anyhow!("{what}: {e}"))?;
            let (tb, to) = m.target;
            let dst = buffers
                .get_mut(tb)
                .and_then(|b| b.get_mut(to..to.checked_add(bytes.len())?))
                .ok_or_else(|| {
                    anyhow!("{what}: the decoded bytes reach past the end of buffer {tb}")
                })?;
            dst.copy_from_slice(&bytes);
        }
        Ok(())
    }
}

/// A meshopt stream's decoded bytes (`count * stride`).
fn decode_stream(src: &[u8], m: &Meshopt) -> Result<Vec<u8>> {
    let fail = |e: meshopt::Error| anyhow!("the {} stream does not decode ({e})", m.mode);
    let bytes = match m.mode.as_str() {
        "ATTRIBUTES" => {
            if m.stride == 0 || !m.stride.is_multiple_of(4) || m.stride > 256 {
                bail!(
                    "ATTRIBUTES byteStride {} is not a multiple of 4 in 4..=256",
                    m.stride
                );
            }
            let mut raw = decode_vertices(src, m.count, m.stride / 4).map_err(fail)?;
            filter(&mut raw, m)?;
            raw
        }
        "TRIANGLES" | "INDICES" => {
            let seq = m.mode == "INDICES";
            if m.mode == "TRIANGLES" && !m.count.is_multiple_of(3) {
                bail!("TRIANGLES count {} is not a multiple of 3", m.count);
            }
            if m.filter != "NONE" {
                bail!("filter {} applies to ATTRIBUTES only", m.filter);
            }
            match m.stride {
                2 => decode_indices::<u16>(src, m.count, seq).map_err(fail)?,
                4 => decode_indices::<u32>(src, m.count, seq).map_err(fail)?,
                s => bail!("{} byteStride {s} is not 2 or 4", m.mode),
            }
        }
        other => bail!(
            "unknown mode '{}' (ATTRIBUTES, TRIANGLES or INDICES)",
            other
        ),
    };
    Ok(bytes)
}

/// `count` indices of type `T` from a TRIANGLES stream, or an INDICES one when `seq`, as
/// bytes.
fn decode_indices<T: meshopt::IndexType + bytemuck::Pod>(
    src: &[u8],
    count: usize,
    seq: bool,
) -> meshopt::Result<Vec<u8>> {
    let v: Vec<T> = if seq {
        meshopt::decode_index_sequence(src, count)?
    } else {
        meshopt::decode_index_buffer(src, count)?
    };
    Ok(bytemuck::cast_slice(&v).to_vec())
}

/// A vertex of `N` 32-bit words: the unit the vertex decoder is handed, one per stride.
#[derive(Clone, Copy)]
struct Words<const N: usize>([u32; N]);

impl<const N: usize> Default for Words<N> {
    fn default() -> Self {
        Words([0; N])
    }
}

fn decode_words<const N: usize>(src: &[u8], count: usize) -> meshopt::Result<Vec<u8>> {
    let v: Vec<Words<N>> = meshopt::decode_vertex_buffer(src, count)?;
    // The decoder wrote raw bytes into the words: native order gives them back.
    Ok(v.iter()
        .flat_map(|w| w.0.iter().flat_map(|x| x.to_ne_bytes()))
        .collect())
}

/// Decodes `count` vertices of `words` 32-bit words (the stride / 4, 1..=64).
fn decode_vertices(src: &[u8], count: usize, words: usize) -> meshopt::Result<Vec<u8>> {
    macro_rules! by_words {
        ($($n:literal)*) => {
            match words {
                $($n => decode_words::<$n>(src, count),)*
                _ => unreachable!("stride checked to 4..=256"),
            }
        };
    }
    by_words!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30
        31 32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59
        60 61 62 63 64)
}

/// Undoes an ATTRIBUTES filter in place.
fn filter(raw: &mut [u8], m: &Meshopt) -> Result<()> {
    match (m.filter.as_str(), m.stride) {
        ("NONE", _) => {}
        ("OCTAHEDRAL", 4) => {
            meshopt::decode_filter_oct::<i8>(bytemuck::cast_slice_mut(raw));
        }
        ("OCTAHEDRAL", 8) => {
            let mut v: Vec<[i16; 4]> = bytemuck::pod_collect_to_vec(raw);
            meshopt::decode_filter_oct::<i16>(&mut v);
            raw.copy_from_slice(bytemuck::cast_slice(&v));
        }
        ("QUATERNION", 8) => {
            let mut v: Vec<[i16; 4]> = bytemuck::pod_collect_to_vec(raw);
            meshopt::decode_filter_quat(&mut v);
            raw.copy_from_slice(bytemuck::cast_slice(&v));
        }
        // Each 32-bit component decodes on its own, whatever the stride.
        ("EXPONENTIAL", _) => {
            let mut v: Vec<[u32; 1]> = bytemuck::pod_collect_to_vec(raw);
            meshopt::decode_filter_exp(&mut v);
            raw.copy_from_slice(bytemuck::cast_slice(&v));
        }
        (f @ ("OCTAHEDRAL" | "QUATERNION"), s) => {
            bail!(
                "filter {f} needs a byteStride of {}, not {s}",
                if f == "QUATERNION" { "8" } else { "4 or 8" }
            )
        }
        (f, _) => bail!("unknown filter '{f}' (NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL)"),
    }
    Ok(())
}

/// A decoded Draco primitive: positions, normals if the stream has them, and the
/// triangle list.
pub struct DracoMesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub indices: Vec<u32>,
}

/// Decodes a Draco stream holding at most `max_points` points and `max_faces` triangles
/// (the primitive's declared counts).
pub fn decode_draco(
    stream: &[u8],
    d: Draco,
    max_points: usize,
    max_faces: usize,
) -> Result<DracoMesh> {
    let limits = draco_core::DecodeLimits::default()
        .with_max_points(max_points as u64)
        .with_max_faces(max_faces as u64);
    let mut buffer = draco_core::DecoderBuffer::new(stream).with_limits(limits);
    let mut mesh = draco_core::Mesh::new();
    draco_core::MeshDecoder::new()
        .decode(&mut buffer, &mut mesh)
        .map_err(|e| anyhow!("the Draco stream does not decode ({})", one_line(&e)))?;
    let points = mesh.num_points();
    if points > max_points {
        bail!("the Draco stream holds {points} points, more than the {max_points} its POSITION accessor declares");
    }
    let vec3s = |id: u32, name: &str| -> Result<Vec<Vec3>> {
        let a = mesh
            .attribute_by_unique_id(id)
            .ok_or_else(|| anyhow!("the Draco stream has no attribute {id} (its {name})"))?;
        if a.num_components() < 3 {
            bail!(
                "the Draco {name} attribute has {} components, not 3",
                a.num_components()
            );
        }
        Ok(a.read_f32s(points, 3)
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    };
    let positions = vec3s(d.position, "POSITION")?;
    let normals = d.normal.map(|n| vec3s(n, "NORMAL")).transpose()?;
    let indices: Vec<u32> = mesh
        .faces()
        .iter()
        .flat_map(|&[a, b, c]| [a.0, b.0, c.0])
        .collect();
    if let Some(k) = indices.iter().position(|&i| i as usize >= points) {
        bail!("the Draco stream's index number {k} is out of range ({points} points)");
    }
    Ok(DracoMesh {
        positions,
        normals,
        indices,
    })
}

fn one_line(e: &dyn std::fmt::Display) -> String {
    e.to_string().replace('\n', " ").trim().to_owned()
}

/// Widens one component's bytes to float, normalized or not.
type Widen = fn(&[u8], bool) -> f32;

/// How to widen one component to float: its byte size and the conversion.
fn component(dt: gltf::accessor::DataType) -> (usize, Widen) {
    use gltf::accessor::DataType as T;
    // glTF 2.0 spec, "Animations" / KHR_mesh_quantization: normalized signed values map
    // c / max, clamped at -1; unsigned c / max.
    match dt {
        T::I8 => (1, |b, n| {
            let c = b[0] as i8 as f32;
            if n {
                (c / 127.0).max(-1.0)
            } else {
                c
            }
        }),
        T::U8 => (1, |b, n| {
            let c = b[0] as f32;
            if n {
                c / 255.0
            } else {
                c
            }
        }),
        T::I16 => (2, |b, n| {
            let c = i16::from_le_bytes([b[0], b[1]]) as f32;
            if n {
                (c / 32767.0).max(-1.0)
            } else {
                c
            }
        }),
        T::U16 => (2, |b, n| {
            let c = u16::from_le_bytes([b[0], b[1]]) as f32;
            if n {
                c / 65535.0
            } else {
                c
            }
        }),
        T::U32 => (4, |b, _| {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32
        }),
        T::F32 => (4, |b, _| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    }
}

/// Whether a VEC3 accessor of this type may hold `attr` (`POSITION` or `NORMAL`): float,
/// or the integer forms KHR_mesh_quantization allows.
pub fn vec3_type_allowed(attr: &str, dt: gltf::accessor::DataType, normalized: bool) -> bool {
    use gltf::accessor::DataType as T;
    match (attr, dt) {
        (_, T::F32) => true,
        ("POSITION", T::I8 | T::U8 | T::I16 | T::U16) => true,
        ("NORMAL", T::I8 | T::I16) => normalized,
        _ => false,
    }
}

/// A VEC3 accessor's elements as floats (range checked by the caller: `check_range`).
pub fn read_vec3(
    a: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    attr: &str,
) -> Result<Vec<Vec3>> {
    let view = a
        .view()
        .ok_or_else(|| anyhow!("{attr} accessor {} has no buffer view", a.index()))?;
    let (size, conv) = component(a.data_type());
    let stride = view.stride().unwrap_or(3 * size);
    let start = view.offset() + a.offset();
    let data = buffers
        .get(view.buffer().index())
        .map(|d| &d.0[..])
        .unwrap_or(&[]);
    let n = a.normalized();
    (0..a.count())
        .map(|k| {
            let at = start + k * stride;
            let e = data
                .get(at..at + 3 * size)
                .ok_or_else(|| anyhow!("{attr} reaches past the end of its buffer"))?;
            Ok(Vec3::new(
                conv(&e[..size], n),
                conv(&e[size..2 * size], n),
                conv(&e[2 * size..], n),
            ))
        })
        .collect()
}
