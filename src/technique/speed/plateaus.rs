//! The speed layer of `plateaus` and `plateaus-centred`: where the light passes clear and
//! draw, and where the final pass runs the technique's shader. `--plain` turns it off
//! (`Settings::effective`): whole textures, whole maps, one full-screen final pass, the
//! same image (tests/plain.rs).
//!
//! - The plateau textures (the paper form's texture and z-buffer; the centred form's
//!   coverage, plateau and inner images) are cleared and drawn only over the texels the
//!   final pass can read (`texture_texels`: the final pass's regions taken back onto the
//!   plane, which hold every drop shadow, cone and sheet), joined with last frame's:
//!   every texel outside holds the clear value, as in whole passes.
//! - The casters-only shadow map is cleared and drawn only over the casters' projected
//!   boxes, joined with last frame's (`regions::AroundCasters::map_area`).
//! - The final pass (`FinalPass::split`) runs the shader only where its visibility can be
//!   below 1 (`Shadowed`): per caster a 16-sided polygon in light uv, on the plane the hull
//!   of its silhouette vertices' discs (P1, P2), which holds its drop shadow (the central
//!   projection of a mesh below the light is its silhouette vertices' hull) and its cones
//!   and sheets (each in the hull of its discs), grown by the bilinear footprint and by the
//!   parallax of points up to the on-plane tolerance off the plane (`plane_region`);
//!   joined, for a caster in the light, with its outline there, which the shadow map's
//!   lookups see. Elsewhere glsl/common/unshadowed.frag writes 1: the whole pass's image
//!   bit for bit (tests/avoided_work.rs). A CPU driver pays both of the final shader's
//!   paths on every pixel it draws; a GPU may need none of this.

use super::super::plateaus_common::{PlaneFrame, MAX_HEIGHT_FRACTION};
use super::super::FrameInput;
use crate::frustum::PixelBox;
use crate::gpu::passes::{MapArea, Shadowed};
use crate::technique::regions::{self, Support};
use crate::vk::Rect2D;
use glam::Vec2;

/// What the speed layer keeps between frames for one plateaus form.
pub(crate) struct PlateauAreas {
    /// The casters' outlines in the light, for the shadow map's part of the final pass.
    around: regions::AroundCasters,
    /// Where the final pass's visibility can be below 1 (`Everywhere`: not known).
    shadowed: Shadowed,
    /// The plateau textures' texels the last light passes may have drawn: the next ones
    /// clear them with their own.
    texture_drawn: regions::LastDrawn,
}

/// Where a frame's light passes clear and draw.
pub(crate) struct Areas {
    /// The plateau textures' render area (`None`: the whole texture).
    pub texture: Option<Rect2D>,
    /// The casters-only shadow map's.
    pub map: MapArea,
}

impl PlateauAreas {
    pub fn new() -> Self {
        Self {
            around: regions::AroundCasters::default(),
            shadowed: Shadowed::Everywhere,
            texture_drawn: regions::LastDrawn::default(),
        }
    }

    /// Plans a frame: where its final pass runs the shader (`shadowed`) and where its light
    /// passes draw. `plane_object` is the planar receiver's object; `reach(i)` caster i's
    /// `PlateauBuilder::reach` for this frame's geometry (`None`: not built). `soft`: the
    /// frame draws plateaus (R > 0, light above the plane).
    pub fn plan(
        &mut self,
        frame: &FrameInput<'_>,
        plane: &PlaneFrame,
        plane_object: usize,
        soft: bool,
        reach: impl Fn(usize) -> Option<Option<Support>>,
    ) -> Areas {
        let res = plane.res;
        // A sun's regions are not planned: its projection is not the central one they
        // follow, so its final pass runs everywhere and its textures are drawn whole.
        let supports = (soft && plane.sun.is_none())
            .then(|| self.shadow_regions(frame, plane, plane_object, reach))
            .flatten();
        self.shadowed = supports.as_ref().map_or(Shadowed::Everywhere, |supports| {
            regions::shadowed(frame, supports, res, 0.0)
        });
        // The plateau textures' texels the final pass can read, joined with last frame's.
        let read = supports.as_ref().and_then(|supports| {
            let margin = regions::lookup_margin(frame, res, 0.0)?;
            texture_texels(frame, plane, supports, margin)
        });
        // The casters-only map's texels, joined with last frame's (both forms).
        let map = self.around.map_area(frame, res);
        let texture = Some(self.texture_drawn.area(read))
            .filter(|_| frame.settings.light_areas)
            .flatten()
            .map(regions::render_area);
        Areas { texture, map }
    }

    /// The last frame's `plan`'s final-pass region, for `FinalPass::pass_in`.
    pub fn shadowed(&self) -> &Shadowed {
        &self.shadowed
    }

    /// Per caster, the light-uv polygon outside which the final pass gives exactly 1: the
    /// plane's texels under its drop shadow and plateaus (`plane_region`), joined, for a
    /// caster in the light, with its outline there (`regions::AroundCasters`), where the
    /// shadow map's lookups can see it. `None` where one is not bounded, or a caster has no
    /// plateaus built for this frame.
    fn shadow_regions(
        &mut self,
        frame: &FrameInput<'_>,
        plane: &PlaneFrame,
        plane_object: usize,
        reach: impl Fn(usize) -> Option<Option<Support>>,
    ) -> Option<Vec<Support>> {
        let mut outlines: Vec<Option<Support>> = vec![None; frame.scene.objects.len()];
        for (i, s) in self.around.outlines(frame)? {
            outlines[i] = Some(s);
        }
        let mut supports = Vec::with_capacity(outlines.len());
        for (i, o) in frame.gpu.objects.iter().enumerate() {
            if !o.role.casts() {
                continue;
            }
            let outline = outlines[i];
            if i == plane_object {
                // The plane casts no plateaus; a casting plane is in the shadow map only.
                supports.extend(outline);
                continue;
            }
            // The drop shadow is the central projection of the caster, bounded by its
            // silhouette vertices' only while every point of it is below the light (h < H).
            let below = o
                .world_corners()
                .iter()
                .all(|&c| plane.height(c) < plane.light_height * MAX_HEIGHT_FRACTION);
            if !below {
                return None;
            }
            let on_plane = plane_region(frame, plane, reach(i)??)?;
            supports.push(match outline {
                Some(s) => regions::union(s, on_plane),
                None => on_plane,
            });
        }
        Some(supports)
    }
}

/// The light-uv polygon around the plane's texels that a caster's drop shadow and
/// plateaus can darken, from the support `reach` of its silhouette vertices' discs in
/// plane coordinates (`PlateauBuilder::reach`), grown by what the final pass reads around
/// a point: the 2x2 bilinear footprint (within 1.5 texels; 2 here), and the parallax of an
/// on-plane point up to `tolerance` off the plane, which reads the texture at its foot f
/// while the light sees it at f + (f - foot of the light) h / (H - h). The plane polygon's
/// corners go to the light's uv, whose projective map keeps the polygon convex in front of
/// the light. `None` when unbounded or not all in front of the light.
fn plane_region(frame: &FrameInput<'_>, plane: &PlaneFrame, reach: Support) -> Option<Support> {
    let grow = |s: Support, by: f32| s.map(|x| x + by);
    let footprint = grow(reach, 2.0 * plane.texel());
    let foot = plane.coords(plane.light);
    let far = regions::support_corners(&footprint)?
        .iter()
        .map(|c| c.distance(foot))
        .fold(0.0, f32::max);
    let room = plane.light_height - plane.tolerance;
    // Also false for NaN.
    if room.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let corners = regions::support_corners(&grow(footprint, far * plane.tolerance / room))?;
    let uvs = corners
        .iter()
        .map(|c| regions::light_uv(frame, plane.origin + plane.u * c.x + plane.v * c.y))
        .collect::<Option<Vec<_>>>()?;
    regions::support_of(&uvs)
}

/// The plateau texture's texels (side `plane.res`) that the final pass's shader can read
/// in the regions around `supports` (light uv polygons, widened by `margin` as
/// `regions::shadowed` widens them): each polygon's corners taken back onto the plane
/// along the light's rays (a projective map: the polygon's points land in their corners'
/// hull), grown by the on-plane parallax (a point up to `tolerance` off the plane reads at
/// its foot, up to |f - foot of the light| tolerance / H from where its ray meets the
/// plane) and the bilinear footprint. Every drop shadow, cone and sheet lies inside (each
/// caster's `plane_region` is in its polygon), so clearing and drawing the plateau textures
/// there only gives the texels the whole passes give wherever the shader reads. `None` (the
/// whole texture) where a corner's ray does not meet the plane in front of the light.
fn texture_texels(
    frame: &FrameInput<'_>,
    plane: &PlaneFrame,
    supports: &[Support],
    margin: f32,
) -> Option<PixelBox> {
    let to_world = frame.light.view_proj.inverse();
    let foot = plane.coords(plane.light);
    let mut texels = PixelBox::EMPTY;
    for support in supports {
        let corners = regions::support_corners(&support.map(|s| s + margin))?;
        let (mut lo, mut hi, mut far) = (Vec2::INFINITY, Vec2::NEG_INFINITY, 0.0f32);
        for uv in corners {
            let ndc = uv * 2.0 - Vec2::ONE;
            let dir = to_world.project_point3(ndc.extend(1.0)) - plane.light;
            // The ray L + t dir meets the plane at t = -H / (n . dir), in front if t > 0.
            let down = plane.n.dot(dir);
            if down.partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
                return None;
            }
            let at = plane.coords(plane.light - dir * (plane.light_height / down));
            far = far.max(at.distance(foot));
            lo = lo.min(at);
            hi = hi.max(at);
        }
        let grow = far * plane.tolerance / plane.light_height + 2.0 * plane.texel();
        let (lo, hi) = (plane.uv(lo - grow), plane.uv(hi + grow));
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        texels = texels.union(PixelBox::of_uv(plane.res, lo, hi));
    }
    Some(texels)
}
