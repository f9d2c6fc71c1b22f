//! GPU silhouettes: the CPU path of this module's parent (`extract`, then `build_smoothies`
//! or `penumbra::build_penumbra`) as a few compute dispatches, writing the geometry straight
//! into a vertex buffer drawn with one indirect draw per caster: no readback, no per-frame
//! upload but the casters' transforms (Chan & Durand's hoped-for "render to vertex array";
//! the seeds all name the CPU silhouette upload as their bottleneck). One struct, two sets of
//! emitters: [`GpuSilhouettes::new`] builds smoothies (`smoothies`),
//! [`GpuSilhouettes::new_penumbra`] cones and sheets (`penumbra-map`); the buffers, the
//! classification, the regions, the partial rebuilds and the draws are shared.
//!
//! # Passes (each ONE dispatch of `glsl/silhouette/*.comp` over every caster at once: on
//! lavapipe a dispatch costs about as much as 3k edges of work, and `dense` has 36 casters)
//! Every first pass runs `classify` (glsl/silhouette/silhouette.glsl) per edge: the facing
//! test of its faces, the classification (boundary / manifold / non-manifold) and the
//! orientation, written to `sil`; then lists the edge at both welded ends (`incident`, up to
//! 16 per vertex).
//!
//! Smoothies:
//! 1. `edges.comp`, one thread per edge: `classify`, and for a silhouette edge its smoothie
//!    quad (6 vertices, appended with an atomic counter) and its outward direction.
//! 2. `corners.comp`, one thread per welded vertex: the corner fan where kept edges meet
//!    (two edges: the arc between them; an even number up to 16: the same per pair of
//!    nearest directions; else the paper's special case).
//! 3. `finish.comp`, one thread per caster: its `VkDrawIndirectCommand`, clamped to its
//!    region of the vertex buffer.
//!
//! Penumbra map (`glsl/silhouette/penumbra.glsl` mirrors `penumbra.rs`):
//! 1. `penumbra_edges.comp`, one thread per edge: `classify`; both ends of a silhouette edge
//!    folded into the caster's bounding box of `blocker_reach` (atomicMax on order-preserving
//!    keys of the tangent-unit points) or its "a vertex was skipped" flag.
//! 2. `penumbra_reach.comp`, one thread per welded vertex on a silhouette: its distance from
//!    the box centre, atomicMax'ed as float bits into the caster's `reach` (the bounding
//!    circle's radius; all emitters read it).
//! 3. `penumbra_emit.comp`, one thread per edge then one per welded vertex: the sheet of a
//!    silhouette edge (6 vertices); the cone of a silhouette vertex (3 x up to
//!    `CONE_SEGMENTS`), whose arc needs the sheet normals of its edges, recomputed from
//!    their ends rather than waiting for another dispatch.
//! 4. `finish.comp`, as above.
//!
//! Threads of a caster that did not move (and whose light did not change) return at once:
//! its region and draw command stay as they were (partial rebuilds).
//!
//! The shaders mirror `silhouette::extract`, `smoothie::build_smoothies_width` and
//! `penumbra::build_penumbra` rule for rule. The facing test is `precise` (no fused
//! multiply-add) with the CPU's operation order and the CPU's object-space light, so both
//! paths find exactly the same silhouette edges (`tests/gpu_silhouettes.rs` compares them as
//! sets). The vertices may differ in the last bits (GPU sin/cos/atan, fused multiply-adds;
//! `tests/gpu_penumbra.rs` matches the cones and sheets to 1e-4 relative, ~1e-5 seen), and
//! their order differs (atomics): both passes that draw them MIN-blend, so the order does
//! not change the image.
//!
//! # Buffers
//! Every caster's data one after the other, indices rebased. Static (built once from each
//! `Adjacency`): positions (vec4), triangles (uvec4, w = degenerate), face normals (vec4),
//! edges (uvec4: ends, first face entry, face count), edge faces (face << 1 | forward), the
//! caster of each edge and of each welded vertex. Per frame: the casters' transforms (128
//! bytes each, the only upload besides the penumbra emitters' 144-byte light), `sil` (u32 per
//! edge), `edge_dir` (vec2 per edge, smoothies), `incident_count` (cleared) and `incident`
//! (16 u32 per vertex), `requested` (u32 per caster, cleared), the penumbra emitters' reach
//! state (8 u32 per caster, cleared), the draw commands (16 bytes per caster) and the vertex
//! buffer (`SmoothieVertex` or `PenumbraVertex`), one region per caster.
//!
//! # Capacity
//! A caster's region starts at 1.5x what the CPU path builds for the scene's own light,
//! plus 1024 vertices. A frame that needs more draws what fits (the shaders never write past
//! a region), and the next frame's `prepare` grows the regions to 1.5x the request, with a
//! warning on stderr: only a caster whose geometry grows by half in one frame loses some,
//! for one frame.
//!
//! # Limits
//! A vertex where more than 16 silhouette edges meet keeps 16 of them (an arbitrary 16: the
//! atomics decide) for its special-case fan; the CPU path keeps all. Both draw the full
//! disc there (`MAX_PAIRED_EDGES`), so silhouettes and coverage agree; the spokes may
//! differ. The penumbra emitters draw a whole cone at such a vertex (the CPU path draws an
//! arc when exactly two of its edges have sheets).

use super::penumbra::{build_penumbra, PenumbraKey, PenumbraVertex};
use super::smoothie::records::Extent;
use super::smoothie::{build_smoothies_width, GeometryKey, Width};
use super::{extract, light_in_object, Adjacency};
use crate::scene::{LightView, Object};
use crate::shaders;
use crate::vk::{
    Buffer, BufferUsageFlags, Context, DescriptorSet, MemoryLocation, Pipeline, Recorder, Resource,
};
use anyhow::{Context as _, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4};
use std::sync::Arc;

/// Slots per welded vertex in `incident` (MAX_INCIDENT in glsl/silhouette/silhouette.glsl).
const MAX_INCIDENT: u64 = 16;
/// Workgroup size of the three shaders.
const GROUP: u32 = 64;
/// Most workgroups in one dispatch dimension (the guaranteed minimum of the limit).
const MAX_GROUPS_X: u32 = 65535;
/// Words of per-caster reach state (REACH_WORDS in glsl/silhouette/penumbra.glsl).
const REACH_WORDS: u64 = 8;
/// Headroom of a caster's region over the CPU estimate (vertices).
const REGION_SLACK: u32 = 1024;

/// Push constants; mirrors `Counts` in glsl/silhouette/silhouette.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct CountsPush {
    /// Edges, welded vertices, casters, 0.
    counts: [u32; 4],
    /// The smoothies' `Extent` (depth, pad, span, 0); zeros (the full width) for the
    /// penumbra-map emitters.
    reach: [f32; 4],
}

/// One caster's per-frame constants; mirrors `Caster` in glsl/silhouette/silhouette.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct CasterData {
    model: [f32; 16],
    /// Columns of the normal matrix; w: the light in object space.
    normal_col: [[f32; 4]; 3],
    /// 1 if mirrored, first vertex of its region, capacity, 1 if rebuilt this frame.
    info: [u32; 4],
}

/// The penumbra emitters' per-frame constants; mirrors `PenumbraFrame` in
/// glsl/silhouette/penumbra.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PenumbraFrame {
    view: [f32; 16],
    view_inv: [f32; 16],
    /// near, z_far, the cones' spread (`penumbra::cone_spread`: Lr, a sun's tan theta), 1
    /// for a sun (orthographic: cones about each vertex's own axis) else 0.
    params: [f32; 4],
}

/// What the passes after the shared classification build from the silhouette edges.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Emitter {
    /// Smoothie quads and corner fans (`SmoothieVertex`).
    Smoothies,
    /// Penumbra-map cones and sheets (`PenumbraVertex`).
    Penumbra,
}

impl Emitter {
    fn vertex_bytes(self) -> u64 {
        match self {
            Emitter::Smoothies => std::mem::size_of::<super::SmoothieVertex>() as u64,
            Emitter::Penumbra => std::mem::size_of::<PenumbraVertex>() as u64,
        }
    }

    fn what(self) -> &'static str {
        match self {
            Emitter::Smoothies => "smoothie",
            Emitter::Penumbra => "penumbra-map",
        }
    }
}

/// What a caster's region was built for besides its model.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BuildKey {
    /// The light and width, and the extent the quads and fans are cut to.
    Smoothies(GeometryKey, Extent),
    Penumbra(PenumbraKey),
}

/// The threads of one dispatch.
#[derive(Clone, Copy, Debug)]
enum Threads {
    Edges,
    Vertices,
    /// Every edge, then every welded vertex.
    EdgesThenVertices,
    Casters,
}

/// Where one caster lives in the concatenated buffers.
struct Caster {
    /// Index into `scene.objects`.
    object: usize,
    /// First edge of this caster in the concatenated arrays.
    edge_base: u32,
    /// Welded ends of every edge (caster-local), to decode `sil`.
    edge_ends: Vec<[u32; 2]>,
    /// Its region of the vertex buffer.
    region_base: u32,
    capacity: u32,
    /// The light and model its region was built for.
    built_for: Option<(BuildKey, Mat4)>,
}

impl Caster {
    /// Its region was built for another light or model (or never).
    fn stale(&self, key: BuildKey, objects: &[Object]) -> bool {
        self.built_for != Some((key, objects[self.object].transform))
    }
}

/// Silhouette edge found by the GPU: (edge index, a, b), caster-local, oriented as
/// `SilhouetteEdge`.
pub type GpuEdge = (u32, u32, u32);

/// Per caster: its object index and the silhouette edges the GPU found.
pub type CasterSilhouettes = Vec<(usize, Vec<GpuEdge>)>;

/// Per caster: its object index and the floats of the vertices its indirect draw draws.
pub type CasterGeometry = Vec<(usize, Vec<f32>)>;

/// The shader blocks of the buffers uploaded once (`statics`), bindings 1..=8.
const STATIC_BLOCKS: [&str; 8] = [
    "Positions",
    "Triangles",
    "FacePlanes",
    "FaceP0yz",
    "Edges",
    "EdgeFaces",
    "EdgeCaster",
    "VertexCaster",
];

/// `edges[].w` of an edge whose faces are listed in `edge_faces` (not exactly two).
const FACE_LIST: u32 = u32::MAX;

/// Decoded `sil` bits (glsl/silhouette/silhouette.glsl).
const SIL_EDGE: u32 = 1;
const SIL_REVERSED: u32 = 2;

/// GPU silhouettes and smoothie (or penumbra-map) geometry of every caster of a scene.
pub struct GpuSilhouettes {
    emitter: Emitter,
    casters: Vec<Caster>,
    edges: u32,
    welded_vertices: u32,
    _statics: Vec<Buffer>,
    caster_data: Buffer,
    sil: Buffer,
    _edge_dir: Buffer,
    incident_count: Buffer,
    _incident: Buffer,
    /// Host-visible: `prepare` reads it.
    requested: Buffer,
    draw_commands: Buffer,
    vertices: Buffer,
    /// Host-visible, penumbra emitters only (zero for smoothies).
    penumbra_frame: Buffer,
    /// Per caster `REACH_WORDS` (cleared every frame; penumbra emitters only).
    reach_state: Buffer,
    set: DescriptorSet,
    /// Set 1: the vertex buffer (replaced when it grows).
    output_set: DescriptorSet,
    /// The dispatches in order: the classification with the first emitter, ..., finish.
    stages: Vec<(Pipeline, Threads)>,
    /// Casters rebuilt by the last `record`.
    rebuilt: usize,
}

/// What a frame's GPU silhouette pass builds for a light (`GpuSilhouettes::frame_pass`):
/// smoothies of a width, cut to an extent (the dispatches' push constants), or penumbra-map
/// cones and sheets for a key.
#[derive(Clone, Copy, Debug)]
pub enum Emit<'a> {
    Smoothies(&'a LightView, Width, Extent),
    Penumbra(&'a LightView, PenumbraKey),
}

impl GpuSilhouettes {
    /// Uploads the adjacency of every caster (`adjacency` zips with `objects`), sized for
    /// the smoothies of `light` with `width`. `None` when no caster has an edge.
    pub fn new(
        ctx: &Context,
        ubo: &Buffer,
        objects: &[Object],
        adjacency: &[Option<Arc<Adjacency>>],
        light: &LightView,
        width: Width,
    ) -> Result<Option<Self>> {
        Self::with_emitter(
            ctx,
            ubo,
            objects,
            adjacency,
            Emitter::Smoothies,
            |adj, o| {
                let sil = extract(adj, o.transform, super::light_point(light));
                build_smoothies_width(adj, &sil, o.transform, light, width)
                    .vertices
                    .len()
            },
        )
    }

    /// The same silhouettes with the penumbra-map emitters: cones and sheets
    /// (`penumbra::build_penumbra`) for a light of radius `radius` with cone bases at depth
    /// `z_far`, sized for `light`. `None` when no caster has an edge.
    pub fn new_penumbra(
        ctx: &Context,
        ubo: &Buffer,
        objects: &[Object],
        adjacency: &[Option<Arc<Adjacency>>],
        light: &LightView,
        radius: f32,
        z_far: f32,
    ) -> Result<Option<Self>> {
        Self::with_emitter(ctx, ubo, objects, adjacency, Emitter::Penumbra, |adj, o| {
            let sil = extract(adj, o.transform, super::light_point(light));
            build_penumbra(adj, &sil, o.transform, light, radius, z_far)
                .vertices
                .len()
        })
    }

    /// The shared buffers and the pipelines of `emitter`; `estimate` is the CPU path's
    /// vertex count of one caster, which sizes its region.
    fn with_emitter(
        ctx: &Context,
        ubo: &Buffer,
        objects: &[Object],
        adjacency: &[Option<Arc<Adjacency>>],
        emitter: Emitter,
        estimate: impl Fn(&Adjacency, &Object) -> usize,
    ) -> Result<Option<Self>> {
        let welded = Welded::gather(objects, adjacency, estimate);
        if welded.casters.is_empty() {
            return Ok(None);
        }
        let statics = welded.upload(ctx)?;
        let n_casters = welded.casters.len() as u64;
        let (n_edges, n_verts) = (welded.edges.len() as u64, welded.positions.len() as u64);
        let w = WorkBuffers::new(ctx, n_casters, n_edges, n_verts)?;
        let vertices = vertex_buffer(ctx, emitter, welded.region_base)?;
        // The blocks of glsl/silhouette/silhouette.glsl and penumbra.glsl, in binding order.
        let mut resources = vec![("frame", Resource::Uniform(ubo))];
        resources.extend(
            STATIC_BLOCKS
                .into_iter()
                .zip(statics.iter().map(Resource::Storage)),
        );
        resources.extend(
            [
                ("Casters", &w.caster_data),
                ("Silhouette", &w.sil),
                ("EdgeDir", &w.edge_dir),
                ("IncidentCount", &w.incident_count),
                ("Incident", &w.incident),
                ("Requested", &w.requested),
                ("DrawCommands", &w.draw_commands),
                ("PenumbraFrame", &w.penumbra_frame),
                ("ReachState", &w.reach_state),
            ]
            .map(|(name, b)| (name, Resource::Storage(b))),
        );
        let set = DescriptorSet::new(ctx, &resources, "silhouettes")?;
        let output_set = output_set(ctx, &vertices)?;
        let stages = stages(ctx, emitter, &[&set, &output_set])?;
        let WorkBuffers {
            caster_data,
            sil,
            edge_dir,
            incident_count,
            incident,
            requested,
            draw_commands,
            penumbra_frame,
            reach_state,
        } = w;
        Ok(Some(Self {
            emitter,
            casters: welded.casters,
            edges: n_edges as u32,
            welded_vertices: n_verts as u32,
            _statics: statics,
            caster_data,
            sil,
            _edge_dir: edge_dir,
            incident_count,
            _incident: incident,
            requested,
            draw_commands,
            vertices,
            penumbra_frame,
            reach_state,
            set,
            output_set,
            stages,
            rebuilt: 0,
        }))
    }

    /// Before recording a frame (the previous one has finished): grows the regions the last
    /// build overflowed. Returns whether the buffer grew.
    pub fn prepare(&mut self, ctx: &Context) -> Result<bool> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(self.requested.read()?);
        let mut grew = false;
        for (c, &asked) in self.casters.iter_mut().zip(&words) {
            if asked > c.capacity {
                let capacity = asked.saturating_add(asked / 2);
                eprintln!(
                    "warning: GPU {} geometry of object {} needed {asked} vertices, {} fit: the last frame lost some; the region grows to {capacity}",
                    self.emitter.what(), c.object, c.capacity
                );
                c.capacity = capacity;
                grew = true;
            }
        }
        if grew {
            let mut base = 0u32;
            for c in &mut self.casters {
                c.region_base = base;
                c.built_for = None;
                base = base.saturating_add(c.capacity);
            }
            self.vertices = vertex_buffer(ctx, self.emitter, base)?;
            self.output_set = output_set(ctx, &self.vertices)?;
            self.requested.write(0, &vec![0; 4 * self.casters.len()])?;
        }
        Ok(grew)
    }

    /// How many casters must be rebuilt for this light and these transforms.
    pub fn dirty(
        &self,
        objects: &[Object],
        light: &LightView,
        width: Width,
        extent: Extent,
    ) -> usize {
        let key = BuildKey::Smoothies(GeometryKey::new(light, width), extent);
        self.dirty_for(objects, key)
    }

    /// `dirty` for the penumbra-map emitters.
    pub fn dirty_penumbra(&self, objects: &[Object], key: PenumbraKey) -> usize {
        self.dirty_for(objects, BuildKey::Penumbra(key))
    }

    fn dirty_for(&self, objects: &[Object], key: BuildKey) -> usize {
        self.casters
            .iter()
            .filter(|c| c.stale(key, objects))
            .count()
    }

    /// Records the smoothie passes for the casters whose model or light changed since their
    /// region was built (all of them when `force`); the recorder puts the barriers between
    /// the dispatches and before the draws.
    pub fn record(
        &mut self,
        rec: &mut Recorder<'_>,
        objects: &[Object],
        light: &LightView,
        width: Width,
        extent: Extent,
        force: bool,
    ) -> Result<()> {
        anyhow::ensure!(
            self.emitter == Emitter::Smoothies,
            "GpuSilhouettes::record on {} emitters",
            self.emitter.what()
        );
        let key = BuildKey::Smoothies(GeometryKey::new(light, width), extent);
        self.record_for(rec, objects, light, key, force)
    }

    /// `record` for the penumbra-map emitters: cones and sheets for `key` (the light's
    /// radius and cone-base depth with `light`).
    pub fn record_penumbra(
        &mut self,
        rec: &mut Recorder<'_>,
        objects: &[Object],
        light: &LightView,
        key: PenumbraKey,
        force: bool,
    ) -> Result<()> {
        anyhow::ensure!(
            self.emitter == Emitter::Penumbra,
            "GpuSilhouettes::record_penumbra on {} emitters",
            self.emitter.what()
        );
        let constants = PenumbraFrame {
            view: light.view.to_cols_array(),
            // The CPU path's own inverse, so both paths place the cone bases alike.
            view_inv: light.view.inverse().to_cols_array(),
            params: [
                key.near,
                key.z_far,
                key.radius,
                if light.sun.is_some() { 1.0 } else { 0.0 },
            ],
        };
        self.penumbra_frame
            .write(0, bytemuck::bytes_of(&constants))?;
        self.record_for(rec, objects, light, BuildKey::Penumbra(key), force)
    }

    fn record_for(
        &mut self,
        rec: &mut Recorder<'_>,
        objects: &[Object],
        light: &LightView,
        key: BuildKey,
        force: bool,
    ) -> Result<()> {
        let data: Vec<CasterData> = self
            .casters
            .iter()
            .map(|c| {
                let dirty = force || c.stale(key, objects);
                caster_data(c, objects[c.object].transform, light, dirty)
            })
            .collect();
        self.caster_data.write(0, bytemuck::cast_slice(&data))?;
        self.rebuilt = data.iter().filter(|d| d.info[3] != 0).count();
        rec.fill_buffer(&self.incident_count, 0);
        rec.fill_buffer(&self.requested, 0);
        if self.emitter == Emitter::Penumbra {
            rec.fill_buffer(&self.reach_state, 0);
        }
        let reach = match key {
            BuildKey::Smoothies(_, e) => [e.depth, e.pad, e.span, 0.0],
            BuildKey::Penumbra(_) => [0.0; 4],
        };
        let push = CountsPush {
            counts: [
                self.edges,
                self.welded_vertices,
                self.casters.len() as u32,
                0,
            ],
            reach,
        };
        for (pipeline, threads) in &self.stages {
            let threads = match threads {
                Threads::Edges => self.edges,
                Threads::Vertices => self.welded_vertices,
                Threads::EdgesThenVertices => self.edges.saturating_add(self.welded_vertices),
                Threads::Casters => self.casters.len() as u32,
            };
            rec.bind_pipeline(pipeline);
            rec.bind_sets(pipeline, &[&self.set, &self.output_set]);
            rec.push_constants(pipeline, bytemuck::bytes_of(&push));
            let groups = threads.div_ceil(GROUP);
            // Meshes with more than 65535 workgroups of edges use the y dimension too.
            let (x, y) = if groups > MAX_GROUPS_X {
                (MAX_GROUPS_X, groups.div_ceil(MAX_GROUPS_X))
            } else {
                (groups, 1)
            };
            rec.dispatch(x, y, 1);
        }
        for c in &mut self.casters {
            c.built_for = Some((key, objects[c.object].transform));
        }
        Ok(())
    }

    /// Casters rebuilt by the last `record` (the others kept their smoothies).
    pub fn rebuilt(&self) -> usize {
        self.rebuilt
    }

    /// A frame's silhouette pass `name` for `emit`: `prepare`, then skipped when no caster's
    /// geometry is stale (unless `force`), else recorded in its own pass, with the casters it
    /// rebuilt out of `casters` reported.
    #[allow(clippy::too_many_arguments)]
    pub fn frame_pass(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        name: &str,
        casters: usize,
        force: bool,
        objects: &[Object],
        emit: Emit<'_>,
    ) -> Result<()> {
        self.prepare(ctx)?;
        let stale = match emit {
            Emit::Smoothies(light, width, extent) => self.dirty(objects, light, width, extent),
            Emit::Penumbra(_, key) => self.dirty_penumbra(objects, key),
        };
        if !force && stale == 0 {
            rec.skip(name, "light and casters unchanged");
            return Ok(());
        }
        rec.pass(name, |rec| match emit {
            Emit::Smoothies(light, width, extent) => {
                self.record(rec, objects, light, width, extent, force)
            }
            Emit::Penumbra(light, key) => self.record_penumbra(rec, objects, light, key, force),
        })?;
        rec.rebuilt(name, self.rebuilt, casters);
        Ok(())
    }

    /// One indirect draw per caster, with the smoothie (or penumbra) pipeline bound.
    pub fn draw(&self, rec: &mut Recorder<'_>) {
        rec.bind_vertex_buffer(&self.vertices);
        for i in 0..self.casters.len() {
            rec.draw_indirect(&self.draw_commands, 16 * i as u64);
        }
    }

    /// The per-edge silhouette flags of every caster (for `decode`, after a readback).
    pub fn silhouette_flags(&self) -> &Buffer {
        &self.sil
    }

    /// The indirect draw commands (4 words per caster) and the vertex buffer, for
    /// `decode_geometry` after a readback.
    pub fn geometry_buffers(&self) -> (&Buffer, &Buffer) {
        (&self.draw_commands, &self.vertices)
    }

    /// Per caster: its object index and the floats of the vertices its draw command draws,
    /// from the words of `geometry_buffers` (`floats`: the whole vertex buffer).
    pub fn decode_geometry(&self, commands: &[u32], floats: &[f32]) -> CasterGeometry {
        let per_vertex = (self.emitter.vertex_bytes() / 4) as usize;
        self.casters
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let cmd = commands.get(4 * i..4 * i + 4).unwrap_or(&[0; 4]);
                let (count, first) = (cmd[0] as usize, cmd[2] as usize);
                let range = first * per_vertex..(first + count) * per_vertex;
                (c.object, floats.get(range).unwrap_or(&[]).to_vec())
            })
            .collect()
    }

    /// The silhouette edges of every caster (object index, caster-local edges) from the
    /// words of `silhouette_flags`.
    pub fn decode(&self, words: &[u32]) -> CasterSilhouettes {
        self.casters
            .iter()
            .map(|c| {
                let start = c.edge_base as usize;
                let mine = words.get(start..start + c.edge_ends.len()).unwrap_or(&[]);
                let edges = mine
                    .iter()
                    .zip(&c.edge_ends)
                    .enumerate()
                    .filter(|(_, (w, _))| **w & SIL_EDGE != 0)
                    .map(|(e, (w, ends))| {
                        let (a, b) = if w & SIL_REVERSED != 0 {
                            (ends[1], ends[0])
                        } else {
                            (ends[0], ends[1])
                        };
                        (e as u32, a, b)
                    })
                    .collect();
                (c.object, edges)
            })
            .collect()
    }
}

/// Every caster's adjacency welded into one set of arrays, indices offset per caster, as the
/// compute passes read them (glsl/silhouette/silhouette.glsl), and each caster's region of
/// the vertex buffer.
#[derive(Default)]
struct Welded {
    casters: Vec<Caster>,
    positions: Vec<[f32; 4]>,
    /// Welded vertex indices, w unused.
    triangles: Vec<[u32; 4]>,
    /// Per face: its normal and the x of its first corner (`p0yz` holds y and z).
    planes: Vec<[f32; 4]>,
    p0yz: Vec<[f32; 2]>,
    /// Per edge: its two vertices and its two faces, or (start in `edge_faces`, FACE_LIST).
    edges: Vec<[u32; 4]>,
    edge_faces: Vec<u32>,
    edge_caster: Vec<u32>,
    vertex_caster: Vec<u32>,
    /// The end of the last region: the vertex buffer's size in vertices.
    region_base: u32,
}

impl Welded {
    /// The casters among `objects` (zipped with `adjacency`) that have edges; `estimate`
    /// sizes each region.
    fn gather(
        objects: &[Object],
        adjacency: &[Option<Arc<Adjacency>>],
        estimate: impl Fn(&Adjacency, &Object) -> usize,
    ) -> Self {
        let mut out = Welded::default();
        for (i, (o, adj)) in objects.iter().zip(adjacency).enumerate() {
            let Some(adj) = adj else { continue };
            if adj.edges.is_empty() {
                continue;
            }
            let id = out.casters.len() as u32;
            let (vbase, fbase) = (out.positions.len() as u32, out.triangles.len() as u32);
            let edge_base = out.edges.len() as u32;
            out.positions
                .extend(adj.positions.iter().map(|p| p.extend(1.0).to_array()));
            out.triangles.extend(
                adj.triangles
                    .iter()
                    .map(|t| [t[0] + vbase, t[1] + vbase, t[2] + vbase, 0]),
            );
            for (t, n) in adj.triangles.iter().zip(&adj.face_normals) {
                // A degenerate face has a zero normal: the shader's "no facing test".
                let p0 = adj.positions[t[0] as usize];
                out.planes.push([n.x, n.y, n.z, p0.x]);
                out.p0yz.push([p0.y, p0.z]);
            }
            for (e, edge) in adj.edges.iter().enumerate() {
                let entry = |f: &super::EdgeFace| (f.face + fbase) << 1 | u32::from(f.forward);
                let (z, w) = match adj.edge_faces(e) {
                    [f0, f1] => (entry(f0), entry(f1)),
                    faces => {
                        let start = out.edge_faces.len() as u32;
                        out.edge_faces.push(faces.len() as u32);
                        out.edge_faces.extend(faces.iter().map(entry));
                        (start, FACE_LIST)
                    }
                };
                out.edges.push([edge.v[0] + vbase, edge.v[1] + vbase, z, w]);
            }
            out.edge_caster
                .extend(std::iter::repeat_n(id, adj.edges.len()));
            out.vertex_caster
                .extend(std::iter::repeat_n(id, adj.positions.len()));
            let estimate = u32::try_from(estimate(adj, o)).unwrap_or(u32::MAX);
            let capacity = estimate
                .saturating_add(estimate / 2)
                .saturating_add(REGION_SLACK);
            out.casters.push(Caster {
                object: i,
                edge_base,
                edge_ends: adj.edges.iter().map(|e| e.v).collect(),
                region_base: out.region_base,
                capacity,
                built_for: None,
            });
            out.region_base = out.region_base.saturating_add(capacity);
        }
        out
    }

    /// The arrays as storage buffers, in the order of `STATIC_BLOCKS` (bindings 1..=8).
    fn upload(&self, ctx: &Context) -> Result<Vec<Buffer>> {
        let upload = |data: &[u8], what: &str| {
            let usage = BufferUsageFlags::STORAGE_BUFFER;
            Buffer::with_data(ctx, data, usage, &format!("silhouettes: {what}"))
        };
        Ok(vec![
            upload(bytemuck::cast_slice(&self.positions), "welded positions")?,
            upload(bytemuck::cast_slice(&self.triangles), "welded triangles")?,
            upload(bytemuck::cast_slice(&self.planes), "face planes")?,
            upload(bytemuck::cast_slice(&self.p0yz), "face corners yz")?,
            upload(bytemuck::cast_slice(&self.edges), "edges")?,
            upload(bytemuck::cast_slice(&self.edge_faces), "edge faces")?,
            upload(bytemuck::cast_slice(&self.edge_caster), "edge casters")?,
            upload(bytemuck::cast_slice(&self.vertex_caster), "vertex casters")?,
        ])
    }
}

/// The buffers the compute passes write, sized for the welded casters (bindings 9..=17).
struct WorkBuffers {
    caster_data: Buffer,
    sil: Buffer,
    edge_dir: Buffer,
    incident_count: Buffer,
    incident: Buffer,
    requested: Buffer,
    draw_commands: Buffer,
    penumbra_frame: Buffer,
    reach_state: Buffer,
}

impl WorkBuffers {
    fn new(ctx: &Context, n_casters: u64, n_edges: u64, n_verts: u64) -> Result<Self> {
        let storage = BufferUsageFlags::STORAGE_BUFFER;
        let gpu = |size: u64, usage: BufferUsageFlags, location: MemoryLocation, what: &str| {
            Buffer::new(ctx, size, usage, location, &format!("silhouettes: {what}"))
        };
        let caster_data = gpu(
            n_casters * std::mem::size_of::<CasterData>() as u64,
            storage,
            MemoryLocation::CpuToGpu,
            "caster transforms",
        )?;
        let sil = gpu(
            4 * n_edges,
            storage | BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
            "silhouette flags",
        )?;
        let edge_dir = gpu(
            8 * n_edges,
            storage,
            MemoryLocation::GpuOnly,
            "edge directions",
        )?;
        let incident_count = gpu(
            4 * n_verts,
            storage | BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            "incident counts",
        )?;
        let incident = gpu(
            4 * MAX_INCIDENT * n_verts,
            storage,
            MemoryLocation::GpuOnly,
            "incident edges",
        )?;
        let mut requested = gpu(
            4 * n_casters,
            storage | BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            "vertices requested",
        )?;
        requested.write(0, &vec![0; 4 * n_casters as usize])?;
        let draw_commands = gpu(
            16 * n_casters,
            storage
                | BufferUsageFlags::INDIRECT_BUFFER
                | BufferUsageFlags::TRANSFER_DST
                | BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
            "draw commands",
        )?;
        let mut penumbra_frame = gpu(
            std::mem::size_of::<PenumbraFrame>() as u64,
            storage,
            MemoryLocation::CpuToGpu,
            "penumbra-map light",
        )?;
        penumbra_frame.write(0, bytemuck::bytes_of(&PenumbraFrame::zeroed()))?;
        let reach_state = gpu(
            4 * REACH_WORDS * n_casters,
            storage | BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            "caster reach",
        )?;
        Ok(Self {
            caster_data,
            sil,
            edge_dir,
            incident_count,
            incident,
            requested,
            draw_commands,
            penumbra_frame,
            reach_state,
        })
    }
}

/// The dispatches of `emitter` in order: the classification with the first emitter, ...,
/// finish, each with what its threads run over.
fn stages(
    ctx: &Context,
    emitter: Emitter,
    sets: &[&DescriptorSet],
) -> Result<Vec<(Pipeline, Threads)>> {
    let push = std::mem::size_of::<CountsPush>() as u32;
    let make = |name: &str, spirv: &[u8]| {
        Pipeline::compute(ctx, name, spirv, sets, push)
            .with_context(|| format!("creating the {name} pipeline"))
    };
    let finish = (
        make("silhouette/finish", shaders::SILHOUETTE_FINISH_COMP)?,
        Threads::Casters,
    );
    Ok(match emitter {
        Emitter::Smoothies => vec![
            (
                make("silhouette/edges", shaders::SILHOUETTE_EDGES_COMP)?,
                Threads::Edges,
            ),
            (
                make("silhouette/corners", shaders::SILHOUETTE_CORNERS_COMP)?,
                Threads::Vertices,
            ),
            finish,
        ],
        Emitter::Penumbra => vec![
            (
                make(
                    "silhouette/penumbra_edges",
                    shaders::SILHOUETTE_PENUMBRA_EDGES_COMP,
                )?,
                Threads::Edges,
            ),
            (
                make(
                    "silhouette/penumbra_reach",
                    shaders::SILHOUETTE_PENUMBRA_REACH_COMP,
                )?,
                Threads::Vertices,
            ),
            (
                make(
                    "silhouette/penumbra_emit",
                    shaders::SILHOUETTE_PENUMBRA_EMIT_COMP,
                )?,
                Threads::EdgesThenVertices,
            ),
            finish,
        ],
    })
}

fn vertex_buffer(ctx: &Context, emitter: Emitter, vertices: u32) -> Result<Buffer> {
    Buffer::new(
        ctx,
        u64::from(vertices) * emitter.vertex_bytes(),
        // TRANSFER_SRC: the tests read the geometry back.
        BufferUsageFlags::STORAGE_BUFFER
            | BufferUsageFlags::VERTEX_BUFFER
            | BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
        &format!("silhouettes: {} vertices", emitter.what()),
    )
}

fn output_set(ctx: &Context, vertices: &Buffer) -> Result<DescriptorSet> {
    DescriptorSet::new(
        ctx,
        &[("Vertices", Resource::Storage(vertices))],
        "silhouettes output",
    )
}

/// The caster's constants: as the CPU path's `Projector`, a singular model gets a zero
/// normal matrix, and the light in object space comes from the same `light_in_object`.
fn caster_data(c: &Caster, model: Mat4, light: &LightView, dirty: bool) -> CasterData {
    let (l, mirror) = light_in_object(model, super::light_point(light));
    let nm = Mat3::from_mat4(model).inverse().transpose();
    let nm = if nm.is_finite() { nm } else { Mat3::ZERO };
    let col = |c: glam::Vec3, w: f32| [c.x, c.y, c.z, w];
    CasterData {
        model: model.to_cols_array(),
        normal_col: [
            col(nm.x_axis, l.x),
            col(nm.y_axis, l.y),
            col(nm.z_axis, l.z),
        ],
        info: [
            u32::from(mirror),
            c.region_base,
            c.capacity,
            u32::from(dirty),
        ],
    }
}
