//! The speed layer: what makes a technique cheaper without being part of it. Each trick
//! keeps the image the plain path gives (tests/plain.rs), and `--plain`
//! (`Settings::effective`) turns each off; the one exception, the soft shadow maps'
//! micro-patch step, says why in `ssm`.
//!
//! - `plateaus` (`plateaus`, `plateaus-centred`): the plateau textures and the casters-only
//!   shadow map cleared and drawn only over the texels the final pass can read (whole
//!   textures under `--plain`), and the split final pass, which runs the technique's shader
//!   only over the casters' regions on the plane and in the light (one full-screen pass
//!   under `--plain`). Saves the clears and draws of unread texels and the final shader's
//!   lookups over lit ground.
//! - `ssm` (`ssm`, `ssm2`, `ssm-bitmask`, `ssm2-bitmask`): the micro-patch step, which
//!   draws the micro-patches in blocks of texels when one patch per texel would shade more
//!   than N^4 / 64 fragments (never on the built-in scenes). Saves the fragments of wide
//!   penumbrae; changes the image where it acts, says so in a warning line, and stays on
//!   under `--plain`.

pub mod plateaus;
pub mod ssm;
