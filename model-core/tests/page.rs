//! The board's parameter page (`model_core::page`): every field once, unique names, words
//! round-trip, and a bad word is refused by its position.

use model_core::board::{BoardParams, ModelKind};
use model_core::page::{from_words, info, to_words, WordError, WordKind, WORDS};
use model_core::{DemandLimits, TyreParams};
use std::collections::BTreeSet;

fn params() -> BoardParams {
    BoardParams::tyres(
        TyreParams::PAPER,
        2,
        DemandLimits {
            min: -1000.0,
            max: 12_000.0,
            rate: 2.0e6,
        },
        1667.7,
        5.0e4,
    )
}

/// Every 4-byte field is visited once: the count is the struct's size over 4.
#[test]
fn every_field_is_one_word() {
    let mut p = params();
    let mut n = 0;
    p.visit(&mut |_, _| n += 1);
    assert_eq!(n, WORDS);
    assert_eq!(WORDS * 4, core::mem::size_of::<BoardParams>());
    println!("{WORDS} words ({} bytes)", 4 * WORDS);
}

/// The names a calibration tool shows are unique, every range is ordered, counts have
/// integral bounds, and the first words select the model.
#[test]
fn names_are_unique_and_ranges_sound() {
    let mut names = BTreeSet::new();
    for k in 0..WORDS {
        let i = info(k).unwrap();
        let name = i.to_string();
        assert!(names.insert(name.clone()), "{name} twice");
        assert!(i.min <= i.max, "{name}");
        if i.kind != WordKind::Real {
            assert_eq!((i.min.fract(), i.max.fract()), (0.0, 0.0), "{name}");
        }
        assert!(!i.unit.is_empty() && !i.description.is_empty(), "{name}");
    }
    assert!(info(WORDS).is_none());
    assert_eq!(
        (info(0).unwrap().to_string(), info(1).unwrap().to_string()),
        ("model_kind".to_string(), "model_channels".to_string())
    );
    assert_eq!(info(2).unwrap().to_string(), "tyre_stiffness_0");
    assert_eq!(
        info(WORDS - 1).unwrap().to_string(),
        "limits_safe_ramp_rate_3"
    );
}

/// Words and parameters convert both ways unchanged, for every model kind.
#[test]
fn words_round_trip() {
    for kind in ModelKind::ALL {
        let mut p = params();
        p.kind = kind as u32;
        p.tyre.tyre[3].lift_off = 0;
        p.substructure.element_count = 2;
        p.substructure.elements[1].law.cubic_stiffness = 3.0e9;
        p.filter[1].sections = 3;
        p.aero.map.front_force[2][5] = -1234.5;
        let words = to_words(&p);
        assert_eq!(words[0], kind as u32 as f32);
        assert_eq!(from_words(&words), Ok(p));
    }
}

/// A word that is not finite, out of its range, or a fraction where a count belongs is
/// refused by its position, whatever the word.
#[test]
fn bad_words_are_refused_by_position() {
    let words = to_words(&params());
    let mut tested = 0;
    for k in (0..WORDS).step_by(7).chain([0, 1, WORDS - 1]) {
        let i = info(k).unwrap();
        let mut w = words;
        w[k] = f32::NAN;
        assert_eq!(from_words(&w), Err(WordError::NotFinite(k)));
        if i.max < f32::MAX {
            w[k] = i.max * 2.0 + 1.0;
            assert_eq!(from_words(&w), Err(WordError::OutOfRange(k)), "{i:?}");
        }
        if i.kind != WordKind::Real {
            w[k] = i.min + 0.5;
            assert_eq!(from_words(&w), Err(WordError::OutOfRange(k)), "{i:?}");
        }
        tested += 1;
    }
    assert!(tested > 80);
}

/// A page read in place sets every field, whatever the place held: into the all-zero
/// blank (what the board keeps in `.bss`) and into a set of other values, the same words
/// give the same set, equal to the one they were made of.
#[test]
fn reading_a_page_in_place_sets_every_field() {
    let mut rich = params();
    rich.kind = ModelKind::Substructure as u32;
    rich.substructure.dof = 2;
    rich.substructure.mass[1][1] = 12.5;
    rich.substructure.elements[3].law.friction_velocity = 2.0e-3;
    rich.aero.map.front_force[2][5] = 321.0;
    rich.filter[3].section[1].alpha2 = 0.25;
    let words = to_words(&rich);
    let word = |k: usize| words.get(k).copied();
    let mut from_zero = BoardParams::ZERO;
    model_core::page::from_words_into(word, &mut from_zero).unwrap();
    let mut from_other = params();
    from_other.aero.map.rear_height[7] = 9.0;
    from_other.substructure.elements[5].law.friction_velocity = 7.0;
    from_other.safe_ramp_rate[3] = 1.0;
    model_core::page::from_words_into(word, &mut from_other).unwrap();
    assert_eq!(from_zero, rich);
    assert_eq!(from_other, rich);
}
