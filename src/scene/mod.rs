//! Scenes: meshes (OBJ through tobj, built-in primitives), objects with a role, one
//! spotlight with a radius, one camera. Built-in scenes by name, TOML scene files, bare
//! OBJ files framed on a ground plane. `export` writes the scene back out for outside tools.

use anyhow::Result;
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// A triangle list. `normals` has one entry per position (computed where the source had none).
/// Positions may be split (flat shading): silhouette code welds them by value.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

/// What an object does for shadows. Every object is seen by the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Casts shadows; its own pixels get visibility 1.
    Caster,
    /// Receives shadows, casts none.
    Receiver,
    /// Casts and receives.
    Both,
}

impl Role {
    pub fn casts(self) -> bool {
        matches!(self, Role::Caster | Role::Both)
    }
    pub fn receives(self) -> bool {
        matches!(self, Role::Receiver | Role::Both)
    }
}

#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: Arc<Mesh>,
    /// Object to world.
    pub transform: Mat4,
    pub role: Role,
    pub albedo: Vec3,
}

/// A spherical light of `radius` at `position`, shadow-mapped as a spotlight towards `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub position: Vec3,
    pub target: Vec3,
    pub fov_deg: f32,
    pub radius: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub objects: Vec<Object>,
    pub light: Light,
    pub camera: Camera,
}

/// Axis-aligned bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

/// The light's shadow-map frame: a square perspective frustum from `Light::position`
/// towards `Light::target`. Light screen space is uv in [0,1]^2 with uv = ndc * 0.5 + 0.5
/// (no flip: rendering and sampling use the same mapping). Linear depth is the distance
/// along the light's view axis (-z in view space); along one texel's ray the ratio of two
/// linear depths equals the ratio of their distances to the light (smoothies' b/r).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    pub position: Vec3,
    pub view: Mat4,
    pub proj: Mat4,
    pub view_proj: Mat4,
    pub near: f32,
    pub far: f32,
    pub fov_deg: f32,
}

impl LightView {
    pub fn new(light: &Light, near: f32, far: f32) -> Self {
        let dir = (light.target - light.position).normalize_or(Vec3::NEG_Z);
        // Any up that is not parallel to the view direction.
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = Mat4::look_at_rh(light.position, light.position + dir, up);
        let proj = Mat4::perspective_rh(light.fov_deg.to_radians(), 1.0, near, far);
        Self {
            position: light.position,
            view,
            proj,
            view_proj: proj * view,
            near,
            far,
            fov_deg: light.fov_deg,
        }
    }

    /// Light-screen uv (in [0,1]^2 inside the frustum) and linear depth of a world point.
    pub fn project(&self, p: Vec3) -> (glam::Vec2, f32) {
        let c = self.view_proj * p.extend(1.0);
        let ndc = c.truncate().truncate() / c.w;
        (ndc * 0.5 + glam::Vec2::splat(0.5), c.w)
    }

    /// Linear depth of a world point (distance along the light's view axis).
    pub fn linear_depth(&self, p: Vec3) -> f32 {
        -(self.view * p.extend(1.0)).z
    }
}
