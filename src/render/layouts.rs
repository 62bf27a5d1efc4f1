//! The GPU records' Rust mirrors (gpu_types.rs and the kinds' own) checked against naga's layout
//! of the WGSL structs they mirror: the record's size, and byte for byte both ways which field
//! holds which member and of what scalar (f32, u32, i32). A field or member added, moved,
//! resized or retyped on one side only fails `every_mirror_matches_naga`, naming both offsets.
//!
//! Sizes: a record's `size_of` is naga's span of its struct, WGSL's SizeOf (the last member's
//! end rounded up to the struct's alignment), which is also the stride of an array of them. It
//! is the same in every address space: the uniform space's stricter rules constrain offsets and
//! strides (naga's validator checks them, shaders.rs's tests) but move no member.

use std::mem::offset_of;

use naga::{Scalar, ScalarKind, TypeInner};

use super::gpu_types::{
    CameraGpu, GdmObjectGpu, IgtEntryGpu, IgtGridGpu, IgtObjectGpu, MeshObjectGpu, MeshTraceGpu,
    PatchGpu, PrismGpu, QueryGpu, QueryHitGpu, QueryRayGpu, SearchGpu, SurfelGpu, SurfelNodeGpu,
    SurfelObjectGpu, SurfelTileGpu, TraceTriangleGpu,
};
use super::kinds::gtex::boxes::PatchBoxGpu;
use super::kinds::tiles::TilesHeader;
use crate::bvh::BvhNodeGpu;

/// `mirror!(Record => "Struct" { field, field: ["member", ...], ... })`: Rust record `Record`
/// mirrors WGSL struct `Struct`. Every field of the record is listed (one left out does not
/// compile); a field holds the WGSL member of its name, or the members listed after it, in order
/// (a nested struct's as "outer.inner"; none for Rust-only padding over a gap in the WGSL
/// layout).
macro_rules! mirror {
    ($t:ident => $wgsl:literal { $($field:ident $(: [$($member:literal),*])?),* $(,)? }) => {{
        // A field left out of the list fails to compile here ("pattern requires `..`").
        let _every_field_listed = |r: &$t| {
            let $t { $($field: _),* } = r;
        };
        Mirror {
            rust: stringify!($t),
            wgsl: $wgsl,
            size: size_of::<$t>(),
            fields: vec![$({
                let (size, scalar) = field(|r: &$t| &r.$field);
                Field {
                    name: stringify!($field),
                    offset: offset_of!($t, $field),
                    size,
                    scalar,
                    members: mirror!(@members $field $([$($member),*])?),
                }
            }),*],
        }
    }};
    (@members $field:ident) => { &[stringify!($field)] };
    (@members $field:ident [$($member:literal),*]) => { &[$($member),*] };
}

/// Every Rust mirror of a WGSL struct, one entry each.
fn mirrors() -> Vec<Mirror> {
    vec![
        mirror!(CameraGpu => "Camera" { clip_from_view, view_from_world, ray, params }),
        mirror!(SearchGpu => "Search" { steps, method }),
        mirror!(PatchGpu => "Patch" {
            view_from_patch, patch_from_view, world_normal_from_patch,
            atlas_origin: ["maps.atlas_origin"], size: ["maps.size"], ids: ["maps.ids"],
            pyramid_at: ["maps.pyramid_at"],
        }),
        mirror!(PatchBoxGpu => "PatchBox" { lo, patch_index, hi, level }),
        mirror!(MeshObjectGpu => "MeshObject" { view_from_object, world_normal_from_object, ids }),
        mirror!(TraceTriangleGpu => "TraceTriangle" { a, _pad0, b, _pad1, c, _pad2 }),
        mirror!(MeshTraceGpu => "MeshTrace" { local_from_query, world_normal_from_local, ids }),
        mirror!(GdmObjectGpu => "GdmObject" {
            view_from_object, object_from_view, world_normal_from_object, size, color, ids, lookup,
            params,
        }),
        mirror!(PrismGpu => "Prism" { corners: ["p0", "p1", "p2", "q0", "q1", "q2"], uv01, uv2 }),
        mirror!(BvhNodeGpu => "BvhNode" { lo, index, hi, leaf }),
        mirror!(QueryRayGpu => "QueryRay" { origin, t_min, dir, _pad }),
        mirror!(QueryHitGpu => "QueryHit" { normal, t, id, _pad: ["_pad0", "_pad1", "_pad2"] }),
        mirror!(QueryGpu => "Query" { counts }),
        mirror!(TilesHeader => "Tiles" {
            size, rect_ndc: ["rect"], grid_from_view, grid, thickness,
        }),
        mirror!(SurfelTileGpu => "SurfelTile" {
            sphere, error, start, info, cone_axis, cone_angle,
        }),
        mirror!(SurfelNodeGpu => "SurfelNode" { sphere, cone, error, surfel, parent, level }),
        mirror!(SurfelGpu => "Surfel" { position, radius, normal, color }),
        mirror!(SurfelObjectGpu => "SurfelObject" {
            view_from_object, world_normal_from_object, planes, params, sizes, rect, counts,
        }),
        mirror!(IgtObjectGpu => "IgtObject" {
            view_from_object, world_normal_from_object, ids, info, object_from_view, segments, lod,
        }),
        mirror!(IgtGridGpu => "IgtGrid" { origin, x, z, size }),
        mirror!(IgtEntryGpu => "IgtEntry" { corners: ["a", "b", "c"], face, grid }),
    ]
}

/// A Rust record and the WGSL struct it mirrors.
struct Mirror {
    rust: &'static str,
    wgsl: &'static str,
    size: usize,
    fields: Vec<Field>,
}

/// A field of a record: where it lies, what scalar it is made of, the WGSL members it holds.
struct Field {
    name: &'static str,
    offset: usize,
    size: usize,
    scalar: Scalar,
    members: &'static [&'static str],
}

/// The scalar a Rust field is made of.
trait Made {
    const OF: Scalar;
}

impl Made for f32 {
    const OF: Scalar = Scalar::F32;
}

impl Made for u32 {
    const OF: Scalar = Scalar::U32;
}

impl Made for i32 {
    const OF: Scalar = Scalar::I32;
}

impl<T: Made, const N: usize> Made for [T; N] {
    const OF: Scalar = T::OF;
}

/// Size and scalar of the field `_get` reads.
fn field<T, F: Made>(_get: fn(&T) -> &F) -> (usize, Scalar) {
    (size_of::<F>(), F::OF)
}

/// A member of a WGSL struct as naga lays it out, a nested struct's flattened ("outer.inner").
struct Member {
    name: String,
    offset: usize,
    size: usize,
    scalar: Option<Scalar>,
}

/// The members of struct `ty` at `base` in naga's layout, nested structs' members in their place.
fn flatten(
    module: &naga::Module,
    layouter: &naga::proc::Layouter,
    ty: naga::Handle<naga::Type>,
    (prefix, base): (&str, usize),
    out: &mut Vec<Member>,
) {
    let TypeInner::Struct { members, .. } = &module.types[ty].inner else {
        unreachable!("members of a struct only")
    };
    for m in members {
        let name = format!("{prefix}{}", m.name.as_deref().unwrap_or("?"));
        let offset = base + m.offset as usize;
        let inner = &module.types[m.ty].inner;
        if let TypeInner::Struct { .. } = inner {
            flatten(module, layouter, m.ty, (&format!("{name}."), offset), out);
        } else {
            out.push(Member {
                name,
                offset,
                size: layouter[m.ty].size as usize,
                scalar: inner.scalar_for_conversions(&module.types),
            });
        }
    }
}

/// A scalar as WGSL spells it.
fn scalar(s: Option<Scalar>) -> String {
    let bits = s.map_or(0, |s| s.width * 8);
    match s.map(|s| s.kind) {
        Some(ScalarKind::Float) => format!("f{bits}"),
        Some(ScalarKind::Uint) => format!("u{bits}"),
        Some(ScalarKind::Sint) => format!("i{bits}"),
        _ => format!("{s:?}"),
    }
}

/// Where mirror `m` and its struct (of naga's `span`, `wgsl` its members) differ.
fn differences(m: &Mirror, span: usize, wgsl: &[Member]) -> Vec<String> {
    let (r, w) = (m.rust, m.wgsl);
    let mut out = Vec::new();
    if m.size != span {
        out.push(format!(
            "{r} is {} bytes, WGSL {w} {span} (naga's span)",
            m.size
        ));
    }
    let mut claimed = vec![false; wgsl.len()];
    for f in &m.fields {
        let (name, end) = (f.name, f.offset + f.size);
        // The field's members lie one after another from its start to its end.
        let (mut at, mut placed) = (f.offset, true);
        for &member in f.members {
            let Some(i) = wgsl.iter().position(|x| x.name == member) else {
                out.push(format!(
                    "{r}.{name} (offset {at}): WGSL {w} has no member {member}"
                ));
                placed = false;
                continue;
            };
            let x = &wgsl[i];
            if x.offset != at {
                let o = x.offset;
                out.push(format!(
                    "{r}.{name} has {w}.{member} at offset {at}, WGSL at {o}"
                ));
                placed = false;
            }
            if x.scalar != Some(f.scalar) {
                let (rk, wk) = (scalar(Some(f.scalar)), scalar(x.scalar));
                out.push(format!(
                    "{r}.{name} is made of {rk}, WGSL {w}.{member} of {wk}"
                ));
            }
            if std::mem::replace(&mut claimed[i], true) {
                out.push(format!("WGSL {w}.{member} is held by two fields of {r}"));
            }
            at = x.offset + x.size;
        }
        if placed && !f.members.is_empty() && at != end {
            out.push(format!(
                "{r}.{name} spans offsets {}..{end}, its WGSL members {:?} end at {at}",
                f.offset, f.members
            ));
        }
        // A field that holds no member (Rust-only padding) lies in a gap of the WGSL layout.
        if f.members.is_empty() {
            for x in wgsl
                .iter()
                .filter(|x| x.offset < end && x.offset + x.size > f.offset)
            {
                let (o, e) = (x.offset, x.offset + x.size);
                out.push(format!(
                    "{r}.{name} (offsets {}..{end}) is padding, WGSL {w}.{} lies at {o}..{e}",
                    f.offset, x.name
                ));
            }
        }
    }
    for (x, _) in wgsl.iter().zip(&claimed).filter(|(_, claimed)| !**claimed) {
        let (o, s) = (x.offset, x.size);
        out.push(format!(
            "WGSL {w}.{} (offset {o}, {s} bytes) is held by no field of {r}",
            x.name
        ));
    }
    out
}

/// Every mirror matches its struct as naga lays it out, in the first pipeline module that
/// declares it (modules share the types files, so each struct is laid out alike in all).
#[test]
fn every_mirror_matches_naga() {
    let mut unchecked = mirrors();
    let mut errors = Vec::new();
    for (name, src) in super::shaders::all() {
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        unchecked.retain(|m| {
            let found = module.types.iter().find(|(_, t)| {
                t.name.as_deref() == Some(m.wgsl) && matches!(t.inner, TypeInner::Struct { .. })
            });
            let Some((ty, t)) = found else {
                return true;
            };
            let TypeInner::Struct { span, .. } = t.inner else {
                unreachable!()
            };
            let mut wgsl = Vec::new();
            flatten(&module, &layouter, ty, ("", 0), &mut wgsl);
            errors.extend(differences(m, span as usize, &wgsl));
            false
        });
    }
    for m in unchecked {
        errors.push(format!(
            "no pipeline module declares struct {} ({})",
            m.wgsl, m.rust
        ));
    }
    assert!(errors.is_empty(), "\n{}", errors.join("\n"));
}
