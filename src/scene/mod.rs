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
