//! The descriptor bindings a shader declares, read from its SPIR-V with spirq, checked
//! against the named descriptor sets a pipeline is made with (see the `vk` header for why).
//! Modules without debug names (the hand-tuned `.spvasm`) are checked for kinds only; their
//! glslang twins, checked by name, declare the same bindings.

use super::pipeline::BindingKind;
use anyhow::{anyhow, bail, Result};
use spirq::ty::{DescriptorType, Type};
use spirq::var::Variable;

/// One `layout(set = S, binding = B)` variable of a module.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ShaderBinding {
    pub set: u32,
    pub binding: u32,
    pub kind: BindingKind,
    /// The variable's GLSL name, or the block's type name when the instance is anonymous
    /// (`buffer Edges { uvec4 edges[]; };` is `Edges`); `None` without debug names.
    pub name: Option<String>,
}

/// Every descriptor binding the module `words` declares (used or not), sorted by (set, binding).
pub(crate) fn bindings(words: &[u32]) -> Result<Vec<ShaderBinding>> {
    let entries = spirq::ReflectConfig::new()
        .spv(words)
        .ref_all_rscs(true)
        .reflect()
        .map_err(|e| anyhow!("reflecting SPIR-V: {e}"))?;
    let mut out: Vec<ShaderBinding> = Vec::new();
    for var in entries.iter().flat_map(|e| &e.vars) {
        let Variable::Descriptor {
            name,
            desc_bind,
            desc_ty,
            ty,
            ..
        } = var
        else {
            continue;
        };
        let kind = match desc_ty {
            DescriptorType::UniformBuffer() => BindingKind::UniformBuffer,
            DescriptorType::StorageBuffer(_) => BindingKind::StorageBuffer,
            DescriptorType::CombinedImageSampler() => BindingKind::SampledImage,
            DescriptorType::StorageImage(_) => BindingKind::StorageImage,
            other => bail!(
                "set {} binding {}: a {other:?}, which this crate does not bind",
                desc_bind.set(),
                desc_bind.bind()
            ),
        };
        let block = match ty {
            Type::Struct(s) => s.name(),
            _ => None,
        };
        let name = name
            .as_deref()
            .filter(|n| !n.is_empty())
            .or(block.filter(|n| !n.is_empty()))
            .map(str::to_owned);
        let b = ShaderBinding {
            set: desc_bind.set(),
            binding: desc_bind.bind(),
            kind,
            name,
        };
        if !out.contains(&b) {
            out.push(b);
        }
    }
    out.sort_by_key(|s| (s.set, s.binding));
    Ok(out)
}

/// What a descriptor set binds at one binding: its kind and the shader variable it is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct HostBinding {
    pub kind: BindingKind,
    pub name: &'static str,
}

/// Every binding `shader` declares against the sets a pipeline is made with (`sets[s][b]`):
/// the binding exists, the kinds agree and, where the module has names, the names agree.
/// The error names the first mismatch.
pub(crate) fn check(shader: &[ShaderBinding], sets: &[&[HostBinding]]) -> Result<()> {
    for s in shader {
        let at = format!(
            "set {} binding {}{}",
            s.set,
            s.binding,
            s.name
                .as_deref()
                .map(|n| format!(" ('{n}' in the shader)"))
                .unwrap_or_default()
        );
        let Some(host) = sets
            .get(s.set as usize)
            .and_then(|set| set.get(s.binding as usize))
        else {
            bail!("{at}: no descriptor set of the pipeline binds it");
        };
        if host.kind != s.kind {
            bail!(
                "{at}: the shader declares a {:?}, the descriptor set binds a {:?} ('{}')",
                s.kind,
                host.kind,
                host.name
            );
        }
        if let Some(want) = s.name.as_deref() {
            if want != host.name {
                bail!("{at}: the descriptor set binds '{}' there", host.name);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(bytes: &[u8]) -> Vec<u32> {
        ash::util::read_spv(&mut std::io::Cursor::new(bytes)).unwrap()
    }

    /// Smoothies' final pass as glslang compiles it: names, kinds and numbers as written in
    /// glsl/smoothies/final.frag.
    #[test]
    fn reads_the_smoothies_final_bindings() {
        let b = bindings(&words(crate::shaders::SMOOTHIES_FINAL_FRAG)).unwrap();
        let got: Vec<_> = b
            .iter()
            .map(|s| (s.set, s.binding, s.kind, s.name.as_deref()))
            .collect();
        use BindingKind::*;
        assert_eq!(
            got,
            [
                (0, 0, UniformBuffer, Some("frame")),
                (0, 1, SampledImage, Some("shadow_map")),
                (0, 2, SampledImage, Some("smoothie_buffer")),
                (0, 3, SampledImage, Some("falloff")),
            ]
        );
    }

    /// An anonymous buffer block is named by its type.
    #[test]
    fn an_anonymous_block_is_named_by_its_type() {
        let b = bindings(&words(crate::shaders::SILHOUETTE_EDGES_COMP)).unwrap();
        let edges = b.iter().find(|s| s.set == 0 && s.binding == 5).unwrap();
        assert_eq!(edges.name.as_deref(), Some("Edges"));
        assert_eq!(edges.kind, BindingKind::StorageBuffer);
    }

    #[test]
    fn a_swapped_pair_is_an_error_naming_the_binding() {
        let shader = bindings(&words(crate::shaders::SMOOTHIES_FINAL_FRAG)).unwrap();
        let sampled = |name| HostBinding {
            kind: BindingKind::SampledImage,
            name,
        };
        let frame = HostBinding {
            kind: BindingKind::UniformBuffer,
            name: "frame",
        };
        let right = [
            frame,
            sampled("shadow_map"),
            sampled("smoothie_buffer"),
            sampled("falloff"),
        ];
        check(&shader, &[&right]).unwrap();
        let swapped = [
            frame,
            sampled("shadow_map"),
            sampled("falloff"),
            sampled("smoothie_buffer"),
        ];
        let e = check(&shader, &[&swapped]).unwrap_err().to_string();
        assert!(
            e.contains("binding 2") && e.contains("'smoothie_buffer'") && e.contains("'falloff'"),
            "{e}"
        );
        let wrong_kind = [HostBinding {
            kind: BindingKind::StorageBuffer,
            name: "frame",
        }];
        let e = check(&shader, &[&wrong_kind]).unwrap_err().to_string();
        assert!(
            e.contains("binding 0") && e.contains("UniformBuffer"),
            "{e}"
        );
        let e = check(&shader, &[&right[..3]]).unwrap_err().to_string();
        assert!(e.contains("binding 3") && e.contains("falloff"), "{e}");
    }

    /// The hand-tuned module has no debug names: kinds are still read, and agree with its
    /// glslang twin's at every binding it declares.
    #[test]
    fn a_module_without_names_is_checked_by_kind() {
        let tuned = bindings(&words(crate::shaders::SMOOTHIES_FINAL_FRAG_SPVASM)).unwrap();
        let glslang = bindings(&words(crate::shaders::SMOOTHIES_FINAL_FRAG)).unwrap();
        assert!(
            !tuned.is_empty() && tuned.iter().all(|s| s.name.is_none()),
            "{tuned:?}"
        );
        for s in &tuned {
            let twin = glslang
                .iter()
                .find(|g| (g.set, g.binding) == (s.set, s.binding));
            assert_eq!(twin.map(|g| g.kind), Some(s.kind), "{s:?}");
        }
    }
}
