//! # The speed layer: what the techniques do that is not the technique
//!
//! Every trick listed here but one saves work without changing an image (the table says where each
//! lives; culling and light-pass reuse are the renderer's, src/render/): a porter may leave
//! all of it out (and on a GPU may need none of it: much of it exists because lavapipe runs
//! every fragment of a pass, both sides of every branch, on the CPU). `--plain`
//! (`Settings::plain`, through `Settings::effective` and `FinalPass::pass_in`) turns every
//! one off, and tests/plain.rs holds the plain and the optimised images equal on every
//! built-in scene for every technique (tests/avoided_work.rs holds each trick on its own).
//! Each technique module names what it uses in one line ("Speed layer: ...").
//!
//! | trick | what it saves | used by | off under `--plain` |
//! |---|---|---|---|
//! | split final pass (`regions::shadowed`, `FinalPass::split`): the final shader only in the screen boxes where a caster's shadow can fall, `glsl/common/unshadowed.frag` elsewhere | the final shader's lookups over lit ground | smoothies, penumbra maps, pcf, pcss, plateaus (and their centred forms) | one full-screen final pass |
//! | light-area-limited clears and draws (`regions::silhouette_areas`, `regions::AroundCasters::map_area`, `regions::LastDrawn`): light buffers cleared and drawn only over the texels a frame reads, joined with last frame's | the clears and the ground's fill of whole light maps | smoothies, penumbra maps, pcf, pcss, plateaus | whole maps, every object (`Settings::light_areas`) |
//! | shortened smoothies (`smoothies::CpuSmoothies`, `records::Extent`, `regions::DeepestGrid`; the GPU path's `smoothies::gpu_extent`): each quad and fan drawn only as wide as Eq. 1 can still write for the deepest receiver under its own reach (the GPU path: under every caster's) | smoothie-pass fragments that are all discarded | smoothies, smoothies-centred | full width t (`Settings::light_areas`) |
//! | cut cones and sheets (`penumbra_map::CpuPenumbra`, `silhouette::penumbra::build_penumbra_sides`, `regions::DeepestGrid`): each cone's and each sheet's base at the deepest receiver under it instead of near the far plane | penumbra-pass fragments that Eq. 1 discards | penumbra-map, penumbra-map-centred | cones and sheets to Z_far (`Settings::light_areas`) |
//! | per-caster geometry caches (`smoothies::CpuSmoothies`, `penumbra_map::CpuPenumbra` over `gpu::passes::CasterCacheOf`) and reused light passes (the renderer skips `record_light` while nothing moved) | rebuilding unchanged geometry and light buffers | the silhouette techniques; every technique | rebuilt every frame (`Settings::cache_light_passes`) |
//! | culling (objects outside the light's or the camera's frustum not drawn) | draws of objects that write no texel read and no pixel | every technique | every object drawn (`Settings::culling`) |
//! | plateau areas and split (`plateaus`): the plateau textures and the casters-only shadow map cleared and drawn only over the texels the final pass can read; the final shader only over the casters' regions on the plane and in the light | the clears and draws of unread texels, the final shader's lookups over lit ground | plateaus, plateaus-centred | whole textures, one full-screen final pass |
//! | receiver tiles and quad list (`ssm::PatchStep`'s tiles, `ssm::QuadList`): each micro-quad derived once by a compute pass, listed only when it reaches a receiver and drawn by one indirect draw, and drawn only as far as the deepest receiver under its extent (16x16-texel tiles of the receiver map) instead of the frame's deepest | a vertex shader run four times per texel of the occluder map, empty ones included, and the fragments of extents sized for the frame's deepest receiver | ssm-bitmask (the tiles: its quads only) | N^2 instances drawn, each vertex deriving its quad, tiles holding z_max (`Settings::light_areas`) |
//! | micro-patch step (`ssm::PatchStep`): the micro-patches drawn in blocks of texels when one patch per texel would shade more than N^4 / 64 fragments (never on the built-in scenes) | the fragments of very wide penumbrae | ssm, ssm2, ssm-bitmask | **stays on**: it changes the image where it acts (a warning line says so), and without it one frame can take minutes |
//!
//! Modules:
//! - `regions`: where a light buffer's texels and a shadow can be (per-caster light-uv
//!   polygons, the light frustum over them, the areas of the light passes), and how deep
//!   a receiver can be over a light-uv box (`deepest_surface`, `DeepestGrid`).
//! - `smoothies`: `smoothies` and `smoothies-centred`: the CPU path's cached smoothie
//!   records and triangles, shortened smoothies, light areas, split polygons.
//! - `penumbra_map`: `penumbra-map` and `penumbra-map-centred`: the CPU path's cached cones
//!   and sheets, cut cones and sheets, light areas, split polygons.
//! - `plateaus`: `plateaus` and `plateaus-centred`: the light-pass areas and the split final
//!   pass's regions.
//! - `ssm`: the soft-shadow-map forms' micro-patch step, and ssm-bitmask's receiver tiles
//!   and quad list.

pub mod penumbra_map;
pub mod plateaus;
pub mod regions;
pub mod smoothies;
pub mod ssm;
