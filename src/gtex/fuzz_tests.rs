//! Fuzzing the .gtex decoder: byte flips and truncations of a valid small file, and
//! structure-aware cases (a field overwritten with an extreme value, the checksum and length then
//! recomputed so the content checks are reached). Whatever the bytes, `decode` returns a set that
//! passes `validate` (and that the CPU consumers take without panicking) or an error: it never
//! panics, aborts or allocates by a count it has not checked against the bytes left.
//!
//! `cargo test` runs a few thousand cases (about a second); the long run is
//! `GTEX_FUZZ_MINUTES=10 cargo test --release fuzz_long -- --ignored --nocapture`.

use glam::DVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

use super::file::{decode, encode};
use super::{GeometryTextureSet, Patch, Stats};

const HEADER: usize = 32;

fn sample() -> Vec<u8> {
    let patch = |bits: u8, w: u32, h: u32, colored: bool| Patch {
        origin: DVec3::new(0.5, -2.0, 1.0),
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        extent: DVec3::new(2.0, 3.0, 0.25),
        width: w,
        height: h,
        height_bits: bits,
        heights: (0..w * h).map(|t| (t * 37 % 200) as u16).collect(),
        // Octahedral codes over the whole range, and texels with no normal.
        normals: (0..w * h)
            .map(|t| match t % 3 {
                0 => super::NO_NORMAL,
                _ => [(t * 71 % 255) as i8 / 2, -((t * 29 % 255) as i8)],
            })
            .collect(),
        // One patch with a color map, one without (the flag and the map's absence).
        colors: if colored {
            vec![[1, 2, 3, 255]; (w * h) as usize]
        } else {
            vec![]
        },
        faces: vec![0, 3],
        ring_faces: vec![5],
        outline: (0..w * h).map(|t| (t * 53 % 255) as u8 as i8).collect(),
        error_bound: None,
    };
    let mut stats = Stats::default();
    stats.set("faces", 6.0);
    stats.seconds.push(("raster".into(), 0.5));
    stats.per_patch = vec![("patch_error".into(), vec![1e-3, 2e-3])];
    encode(&GeometryTextureSet {
        patches: vec![patch(16, 3, 2, true), patch(8, 2, 2, false)],
        texel_size: 0.5,
        stats,
        triangles: None,
    })
}

/// The header's length and checksum made to match the (changed) payload.
fn reseal(bytes: &mut [u8]) {
    if bytes.len() < HEADER {
        return;
    }
    let len = (bytes.len() - HEADER) as u64;
    let crc = crc32fast::hash(&bytes[HEADER..]);
    bytes[16..24].copy_from_slice(&len.to_le_bytes());
    bytes[24..28].copy_from_slice(&crc.to_le_bytes());
}

/// Decodes; a set that comes back must be valid and usable by the CPU consumers.
fn check(bytes: &[u8]) -> Result<(), TestCaseError> {
    if let Ok(set) = decode(bytes) {
        prop_assert_eq!(set.validate(), Ok(()));
        let (points, normals) = set.to_points();
        prop_assert!(points.iter().flatten().all(|x| x.is_finite()));
        prop_assert!(normals.iter().flatten().all(|x| x.is_finite()));
        prop_assert!(set.face_patch().len() <= 1 << 32);
        let rays = [(DVec3::new(0.3, 0.2, 5.0), -DVec3::Z)];
        prop_assert!(crate::heightfield::first_hits(&set, &rays, &crate::cancel::NEVER).is_ok());
    }
    Ok(())
}

/// Values that break fields: zero, one, the largest sizes, just past the limits, NaN, infinities.
fn extreme_u32() -> impl Strategy<Value = u32> {
    prop_oneof![
        Just(0u32),
        Just(1),
        Just(4096),
        Just(4097),
        Just(u32::MAX),
        Just(u32::MAX / 4),
        Just(65535),
        any::<u32>(),
    ]
}

fn extreme_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0f64),
        Just(-0.0),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(1e308),
        Just(-1.0),
        Just(f64::MIN_POSITIVE),
        Just(4.3e9),
        any::<f64>(),
    ]
}

/// One mutation of the sample: flipped bytes (resealed or not), then a truncation, or a field
/// at any offset overwritten with an extreme 4- or 8-byte value and resealed.
fn mutated() -> impl Strategy<Value = Vec<u8>> {
    let n = sample().len();
    let flips = (
        proptest::collection::vec((0..n, any::<u8>()), 1..8),
        any::<bool>(),
        0..=n,
    )
        .prop_map(|(flips, seal, cut)| {
            let mut b = sample();
            for (i, x) in flips {
                b[i] ^= x.max(1);
            }
            if seal {
                reseal(&mut b);
            }
            b.truncate(cut.max(HEADER.min(cut)));
            b
        });
    let fields = (
        HEADER..n,
        prop_oneof![
            extreme_u32().prop_map(|v| v.to_le_bytes().to_vec()),
            extreme_f64().prop_map(|v| v.to_le_bytes().to_vec()),
        ],
        any::<bool>(),
    )
        .prop_map(move |(at, value, cut)| {
            let mut b = sample();
            let end = (at + value.len()).min(n);
            b[at..end].copy_from_slice(&value[..end - at]);
            if cut {
                b.truncate(end); // a field that now claims more than is left
            }
            reseal(&mut b);
            b
        });
    prop_oneof![flips, fields]
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    })
}

#[test]
fn the_sample_decodes() {
    assert!(decode(&sample()).is_ok());
}

#[test]
fn every_truncation_and_every_extreme_field_is_an_error_or_a_valid_set() {
    let b = sample();
    for cut in 0..b.len() {
        assert!(decode(&b[..cut]).is_err(), "cut at {cut}");
        let mut sealed = b[..cut].to_vec();
        reseal(&mut sealed);
        check(&sealed).unwrap();
    }
    let values: Vec<Vec<u8>> = [0u32, 1, 4097, u32::MAX]
        .iter()
        .map(|v| v.to_le_bytes().to_vec())
        .chain(
            [f64::NAN, f64::INFINITY, 0.0, -1.0, 1e308]
                .iter()
                .map(|v| v.to_le_bytes().to_vec()),
        )
        .collect();
    for at in HEADER..b.len() {
        for v in &values {
            let mut c = b.clone();
            let end = (at + v.len()).min(c.len());
            c[at..end].copy_from_slice(&v[..end - at]);
            reseal(&mut c);
            check(&c).unwrap();
        }
    }
}

#[test]
fn random_mutations_never_panic() {
    runner(3000).run(&mutated(), |b| check(&b)).unwrap();
}

/// The long run: `GTEX_FUZZ_MINUTES` minutes (default 10) of random mutations in batches.
#[test]
#[ignore]
fn fuzz_long() {
    let minutes: f64 = std::env::var("GTEX_FUZZ_MINUTES")
        .ok()
        .and_then(|m| m.parse().ok())
        .unwrap_or(10.0);
    let start = std::time::Instant::now();
    let mut cases = 0u64;
    while start.elapsed().as_secs_f64() < minutes * 60.0 {
        runner(100_000).run(&mutated(), |b| check(&b)).unwrap();
        cases += 100_000;
    }
    println!(
        "fuzz_long: {cases} cases in {:.1} minutes, no failure",
        start.elapsed().as_secs_f64() / 60.0
    );
}
