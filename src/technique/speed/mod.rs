//! The speed layer: what makes a technique cheaper without being part of it. Each trick
//! keeps the image the plain path gives (tests/plain.rs), and `--plain`
//! (`Settings::effective`) turns each off.
//!
//! - `plateaus` (`plateaus`, `plateaus-centred`): the plateau textures and the casters-only
//!   shadow map cleared and drawn only over the texels the final pass can read (whole
//!   textures under `--plain`), and the split final pass, which runs the technique's shader
//!   only over the casters' regions on the plane and in the light (one full-screen pass
//!   under `--plain`). Saves the clears and draws of unread texels and the final shader's
//!   lookups over lit ground.

pub mod plateaus;
