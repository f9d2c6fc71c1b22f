//! The scene on the GPU: one vertex buffer (position, normal) and one index buffer per
//! object, drawn with the object's model matrix and albedo as push constants.

use crate::scene::{Object, Role, Scene};
use crate::vk::{Attribute, Buffer, BufferUsageFlags, Context, Format, Pipeline, Recorder};
use anyhow::Result;
use bytemuck::{Pod, Zeroable};
use glam::Mat4;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SceneVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
}

/// Vertex layout of `SceneVertex` (locations 0 and 1).
pub const SCENE_VERTEX_STRIDE: u32 = std::mem::size_of::<SceneVertex>() as u32;
pub const SCENE_ATTRIBUTES: &[Attribute] = &[
    (0, Format::R32G32B32_SFLOAT, 0),
    (1, Format::R32G32B32_SFLOAT, 12),
];

/// Push constants of one draw; mirrors `Draw` in glsl/common/frame.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct DrawPush {
    pub model: [f32; 16],
    pub albedo_receives: [f32; 4],
    /// x: 1 if the object casts shadows.
    pub flags: [f32; 4],
}

pub const DRAW_PUSH_BYTES: u32 = std::mem::size_of::<DrawPush>() as u32;

pub struct GpuObject {
    /// Object-space bounds, for culling.
    pub local_bounds: crate::scene::Aabb,
    /// Intersects the light frustum this frame (or culling is off).
    pub in_light: bool,
    /// Intersects the camera frustum this frame (or culling is off).
    pub in_camera: bool,
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
    pub model: Mat4,
    pub role: Role,
    pub albedo: glam::Vec3,
}

impl GpuObject {
    /// The corners of the object's box in the world (`Aabb::corners`' order).
    pub fn world_corners(&self) -> [glam::Vec3; 8] {
        self.local_bounds
            .corners()
            .map(|c| self.model.transform_point3(c))
    }
}

impl DrawPush {
    /// The constants of one object's draws.
    pub fn new(model: Mat4, albedo: glam::Vec3, role: Role) -> Self {
        Self {
            model: model.to_cols_array(),
            albedo_receives: [
                albedo.x,
                albedo.y,
                albedo.z,
                if role.receives() { 1.0 } else { 0.0 },
            ],
            // yzw: albedo^(1/2.2), so that the final pass gamma-encodes with one scalar pow a
            // pixel (glsl/common/final.glsl).
            flags: [
                if role.casts() { 1.0 } else { 0.0 },
                albedo.x.powf(1.0 / 2.2),
                albedo.y.powf(1.0 / 2.2),
                albedo.z.powf(1.0 / 2.2),
            ],
        }
    }
}

impl GpuObject {
    fn push(&self) -> DrawPush {
        DrawPush::new(self.model, self.albedo, self.role)
    }
}

pub struct GpuScene {
    pub objects: Vec<GpuObject>,
}

impl GpuScene {
    pub fn new(ctx: &Context, scene: &Scene) -> Result<Self> {
        let objects = scene
            .objects
            .iter()
            .map(|o| upload(ctx, o))
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { objects })
    }

    /// Updates the model matrices (object motion) without re-uploading meshes.
    pub fn set_transforms(&mut self, scene: &Scene) {
        for (g, o) in self.objects.iter_mut().zip(&scene.objects) {
            g.model = o.transform;
        }
    }

    /// Frustum culling: marks which objects intersect the light's and the camera's frustum
    /// (everything, when `enabled` is false). Returns whether any caster is in the light's.
    pub fn cull(&mut self, light_view_proj: Mat4, camera_view_proj: Mat4, enabled: bool) -> bool {
        for o in &mut self.objects {
            let world = o.local_bounds.transform(&o.model);
            o.in_light = !enabled || intersects_frustum(&world, light_view_proj);
            o.in_camera = !enabled || intersects_frustum(&world, camera_view_proj);
        }
        self.objects.iter().any(|o| o.in_light && o.role.casts())
    }

    /// How many objects `cull` kept: (in the light's frustum, in the camera's).
    pub fn in_frusta(&self) -> (usize, usize) {
        let light = self.objects.iter().filter(|o| o.in_light).count();
        let camera = self.objects.iter().filter(|o| o.in_camera).count();
        (light, camera)
    }

    /// Draws, from the light, every object in the light frustum for which `filter` holds,
    /// with pipeline `p` (already bound).
    pub fn draw(&self, rec: &mut Recorder<'_>, p: &Pipeline, filter: impl Fn(&GpuObject) -> bool) {
        self.draw_where(rec, p, |o| o.in_light && filter(o));
    }

    /// Draws, from the camera, every object in the camera frustum.
    pub fn draw_camera(&self, rec: &mut Recorder<'_>, p: &Pipeline) {
        self.draw_where(rec, p, |o| o.in_camera);
    }

    /// Draws object `i`, whatever its culling flags.
    pub fn draw_object(&self, rec: &mut Recorder<'_>, p: &Pipeline, i: usize) {
        if let Some(o) = self.objects.get(i) {
            Self::draw_one(rec, p, o);
        }
    }

    fn draw_where(
        &self,
        rec: &mut Recorder<'_>,
        p: &Pipeline,
        filter: impl Fn(&GpuObject) -> bool,
    ) {
        for o in self.objects.iter().filter(|o| filter(o)) {
            Self::draw_one(rec, p, o);
        }
    }

    fn draw_one(rec: &mut Recorder<'_>, p: &Pipeline, o: &GpuObject) {
        rec.push_constants(p, bytemuck::bytes_of(&o.push()));
        rec.bind_vertex_buffer(&o.vertices);
        rec.bind_index_buffer(&o.indices);
        rec.draw_indexed(o.index_count);
    }
}

/// Conservative: false only when all 8 corners lie outside one clip plane.
fn intersects_frustum(b: &crate::scene::Aabb, view_proj: Mat4) -> bool {
    let corners = b.corners().map(|c| view_proj * c.extend(1.0));
    let outside = |f: &dyn Fn(&glam::Vec4) -> bool| corners.iter().all(f);
    !(outside(&|c| c.x < -c.w)
        || outside(&|c| c.x > c.w)
        || outside(&|c| c.y < -c.w)
        || outside(&|c| c.y > c.w)
        || outside(&|c| c.z < 0.0)
        || outside(&|c| c.z > c.w))
}

fn upload(ctx: &Context, o: &Object) -> Result<GpuObject> {
    let m = &o.mesh;
    let vertices: Vec<SceneVertex> = m
        .positions
        .iter()
        .zip(&m.normals)
        .map(|(p, n)| SceneVertex {
            position: p.to_array(),
            normal: n.to_array(),
        })
        .collect();
    Ok(GpuObject {
        local_bounds: m.bounds(),
        in_light: true,
        in_camera: true,
        vertices: Buffer::with_data(
            ctx,
            bytemuck::cast_slice(&vertices),
            BufferUsageFlags::VERTEX_BUFFER | BufferUsageFlags::STORAGE_BUFFER,
            &format!("{} vertices", o.name),
        )?,
        indices: Buffer::with_data(
            ctx,
            bytemuck::cast_slice(&m.indices),
            BufferUsageFlags::INDEX_BUFFER | BufferUsageFlags::STORAGE_BUFFER,
            &format!("{} indices", o.name),
        )?,
        index_count: m.indices.len() as u32,
        model: o.transform,
        role: o.role,
        albedo: o.albedo,
    })
}
