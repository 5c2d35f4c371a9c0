//! `mil param list | get | set | store`: the board's calibration parameters by their A2L
//! names.
//!
//! - `list` needs the A2L file only: every parameter with unit, limits, address and
//!   description, then the measurements (`mil daq record --signals`).
//! - `get NAME...` reads the values (contiguous parameters in one upload).
//! - `set NAME=VALUE...` checks every value on the host first (finite, within the A2L
//!   limits) and sends nothing when one fails; then CAL/PAG is unlocked by seed & key, the
//!   values of contiguous parameters go to the board as ONE change (validated by the board as
//!   a whole), others one after another, and each parameter is printed `old → new` as read
//!   back. A value the board still refuses is reported with its reason; that change is not
//!   applied.
//! - `store` saves the board's working page to its flash (XCP SET_REQUEST STORE_CAL_REQ, CAL/PAG
//!   unlocked): the board boots it from then on. Refused while the controller runs; the
//!   outcome is read back from the board's measurements.

use std::fmt::Write as _;

use anyhow::{anyhow, bail, Result};
use mil_can::Transport;
use mil_xcp_master::{resource, A2l, Change, Item, Master};

use crate::xcp::{format_limit, format_value};

/// The table `mil param list` prints.
pub fn list_table(a2l: &A2l) -> String {
    let mut t = String::new();
    let w = |items: &[Item], t: &mut String| {
        let name_w = items.iter().map(|i| i.name.len()).max().unwrap_or(4).max(4);
        let _ = writeln!(
            t,
            "{:<name_w$}  {:<6} {:>13} {:>13}  {:<10}  description",
            "name", "unit", "min", "max", "address"
        );
        for i in items {
            let _ = writeln!(
                t,
                "{:<name_w$}  {:<6} {:>13} {:>13}  0x{:08X}  {}",
                i.name,
                i.unit_or_dash(),
                format_limit(i.min),
                format_limit(i.max),
                i.address,
                i.description
            );
        }
    };
    let _ = writeln!(
        t,
        "{} calibration parameters ({} {}):",
        a2l.characteristics.len(),
        a2l.project,
        a2l.module
    );
    w(&a2l.characteristics, &mut t);
    let _ = writeln!(
        t,
        "\n{} measurements (mil daq record --signals):",
        a2l.measurements.len()
    );
    w(&a2l.measurements, &mut t);
    for s in &a2l.skipped {
        let _ = writeln!(t, "skipped {}: {}", s.name, s.why);
    }
    t
}

/// `NAME=VALUE` pairs.
///
/// # Errors
/// A pair without `=` or with a value that is not a number.
pub fn parse_assignments(pairs: &[String]) -> Result<Vec<(String, f64)>> {
    pairs
        .iter()
        .map(|p| {
            let (name, value) = p
                .split_once('=')
                .ok_or_else(|| anyhow!("`{p}`: expected NAME=VALUE"))?;
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| anyhow!("`{p}`: `{value}` is not a number"))?;
            Ok((name.trim().to_string(), v))
        })
        .collect()
}

/// The parameters `names` (characteristics first, then measurements, as `get` reads both).
///
/// # Errors
/// A name the A2L does not have.
pub fn resolve<'a>(a2l: &'a A2l, names: &[String]) -> Result<Vec<&'a Item>> {
    names
        .iter()
        .map(|n| {
            a2l.characteristic(n)
                .or_else(|e| a2l.measurement(n).map_err(|_| e))
                .map_err(Into::into)
        })
        .collect()
}

/// `mil param get`: the values of `names`, one `name = value unit` line each.
///
/// # Errors
/// Unknown names, or the board's errors.
pub fn get<T: Transport>(master: &mut Master<T>, a2l: &A2l, names: &[String]) -> Result<String> {
    let items = resolve(a2l, names)?;
    let values = master.read_items(&items)?;
    let width = items.iter().map(|i| i.name.len()).max().unwrap_or(0);
    let mut t = String::new();
    for (i, v) in items.iter().zip(values) {
        let _ = writeln!(
            t,
            "{:<width$} = {} {}",
            i.name,
            format_value(i, v),
            i.unit_or_dash()
        );
    }
    Ok(t)
}

/// Host-side checks of `set`: names known, values finite and within the A2L limits, no
/// parameter twice. Nothing is sent.
///
/// # Errors
/// The first problem.
pub fn check_assignments<'a>(
    a2l: &'a A2l,
    assignments: &[(String, f64)],
) -> Result<(Vec<&'a Item>, Vec<f64>)> {
    if assignments.is_empty() {
        bail!("nothing to set: give NAME=VALUE ...");
    }
    let mut items = Vec::new();
    let mut values = Vec::new();
    for (name, v) in assignments {
        let item = a2l.characteristic(name)?;
        if items.iter().any(|i: &&Item| i.name == item.name) {
            bail!("{name} is given twice");
        }
        item.encode_checked(*v)?;
        items.push(item);
        values.push(*v);
    }
    Ok((items, values))
}

/// `mil param set`: unlocks CAL/PAG with `secret` and writes (see the module
/// documentation); the changes as read back.
///
/// # Errors
/// Host-side check failures (nothing sent), a wrong secret, the board's refusal.
pub fn set<T: Transport>(
    master: &mut Master<T>,
    a2l: &A2l,
    assignments: &[(String, f64)],
    secret: &[u8],
) -> Result<Vec<Change>> {
    let (items, values) = check_assignments(a2l, assignments)?;
    master.unlock(resource::CAL_PAG, secret)?;
    Ok(master.write_items(&items, &values)?)
}

/// `NAME=VALUE` for every calibration parameter of a board page (slot order, A2L names), e.g.
/// [`crate::sim::board_page`]'s for a set-up.
pub fn page_assignments(page: &[f32]) -> Vec<(String, f64)> {
    page.iter()
        .enumerate()
        .filter_map(|(slot, &v)| {
            mil_firmware::calibration::item(slot).map(|item| (item.to_string(), f64::from(v)))
        })
        .collect()
}

/// `mil param set --setup`: unlocks CAL/PAG with `secret` and writes the parameters of
/// `assignments` whose value on the board differs, one change each, in passes: a change the
/// board refuses now (a limit crossing one not yet written, a model kind whose parameters are
/// not yet there) is tried again after the others, until every one is applied or a pass
/// applies none. Returns the changes made.
///
/// # Errors
/// Host-side check failures (nothing sent), a wrong secret, changes the board refuses in
/// every order (named, with the board's last reason).
pub fn set_all<T: Transport>(
    master: &mut Master<T>,
    a2l: &A2l,
    assignments: &[(String, f64)],
    secret: &[u8],
) -> Result<Vec<Change>> {
    let (items, values) = check_assignments(a2l, assignments)?;
    master.unlock(resource::CAL_PAG, secret)?;
    let current = master.read_items(&items)?;
    // The board holds f32: a value equal after rounding to f32 is not written again.
    let mut pending: Vec<usize> = (0..items.len())
        .filter(|&i| current[i] as f32 != values[i] as f32)
        .collect();
    let mut changes = Vec::new();
    while !pending.is_empty() {
        let mut refused = Vec::new();
        let mut last = None;
        for &i in &pending {
            match master.write_items(&[items[i]], &[values[i]]) {
                Ok(c) => changes.extend(c),
                Err(e @ mil_xcp_master::Error::Refused { .. }) => {
                    refused.push(i);
                    last = Some(e);
                }
                Err(e) => return Err(e.into()),
            }
        }
        if refused.len() == pending.len() {
            let names: Vec<&str> = refused.iter().map(|&i| items[i].name.as_str()).collect();
            bail!(
                "the board refuses {} in every order ({} other change(s) applied); last: {}",
                names.join(", "),
                changes.len(),
                last.map_or_else(String::new, |e| e.to_string())
            );
        }
        pending = refused;
    }
    Ok(changes)
}

/// How long `store` waits for the board (a flash sector erase takes seconds).
pub const STORE_WAIT: std::time::Duration = std::time::Duration::from_secs(20);

/// What the board said of a store.
const STORE_ERRORS: [&str; 5] = [
    "stored",
    "the working page does not validate (nothing was written)",
    "the flash refused a write or an erase",
    "read back, the stored page differs from the working page",
    "refused while the controller runs: stop it first",
];

/// `store`: unlocks CAL/PAG, asks the board to store its working page, waits for it and
/// reads back the outcome; the line to print.
///
/// # Errors
/// The board's refusal (e.g. while the controller runs) or a failed store, with its reason.
pub fn store<T: Transport>(master: &mut Master<T>, a2l: &A2l, secret: &[u8]) -> Result<String> {
    master.unlock(resource::CAL_PAG, secret)?;
    let stored = master.store_calibration(STORE_WAIT)?;
    let names = [
        "calibration_stores".to_string(),
        "calibration_store_error".to_string(),
    ];
    let items = resolve(a2l, &names)?;
    let values = master.read_items(&items)?;
    let (count, error) = (values[0], values[1]);
    let why = STORE_ERRORS
        .get(error as usize)
        .copied()
        .unwrap_or("unknown reason");
    if !stored || error != 0.0 {
        bail!("the board did not store its calibration: {why} (calibration_store_error = {error})");
    }
    Ok(format!(
        "stored the working page in the board's flash: it boots with it from now on ({count} stores since boot)\n"
    ))
}

/// The `old → new` lines of `set`.
pub fn changes_table(a2l: &A2l, changes: &[Change]) -> String {
    let width = changes.iter().map(|c| c.name.len()).max().unwrap_or(0);
    let mut t = String::new();
    for c in changes {
        let fmt = |v: f64| match a2l.characteristic(&c.name) {
            Ok(item) => format_value(item, v),
            Err(_) => format!("{v}"),
        };
        let _ = writeln!(
            t,
            "{:<width$}: {} → {} {}",
            c.name,
            fmt(c.old),
            fmt(c.new),
            c.unit
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_parse() {
        let a = parse_assignments(&["tyre_stiffness=2.5e5".into(), " demand_max = 3000 ".into()])
            .unwrap();
        assert_eq!(
            a,
            vec![
                ("tyre_stiffness".into(), 2.5e5),
                ("demand_max".into(), 3000.0)
            ]
        );
        assert_eq!(
            parse_assignments(&["tyre_stiffness".into()])
                .unwrap_err()
                .to_string(),
            "`tyre_stiffness`: expected NAME=VALUE"
        );
        assert!(parse_assignments(&["x=fast".into()]).is_err());
    }
}

#[cfg(test)]
mod setup_tests {
    use super::*;
    use mil_firmware::calibration::{MEASUREMENT_BYTES, PAGE_BYTES, SLOTS};

    /// The A2L of a firmware whose page and measurements sit at made-up addresses.
    fn a2l() -> A2l {
        let block = |address, size: usize| mil_a2l::Block {
            address,
            size: size as u32,
        };
        let layout = mil_a2l::Layout {
            calibration: block(0x2000_8000, PAGE_BYTES),
            measurement: block(0x2000_7000, MEASUREMENT_BYTES),
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mil.a2l");
        std::fs::write(&path, mil_a2l::generate(&layout, "test")).unwrap();
        A2l::load(&path).unwrap()
    }

    /// Every example set-up the board runs becomes one value per calibration parameter, each
    /// named as in the A2L and within its limits (what `mil param set --setup` checks before
    /// it sends anything), the sample rate and the model's channels among them.
    #[test]
    fn every_board_set_up_maps_onto_the_a2l() {
        let a2l = a2l();
        let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
        // tyre.toml's four wheels at 2 kHz need more than the bus: refused, with the rate
        // that fits.
        let tyre = crate::setup::SetUp::read(&examples.join("tyre.toml"))
            .and_then(|s| s.sim())
            .unwrap();
        let e = crate::sim::board_page(&tyre).unwrap_err().to_string();
        assert!(e.contains("it runs at up to"), "{e}");
        for name in ["tyre-board.toml", "aero.toml", "two-dof.toml"] {
            let config = crate::setup::SetUp::read(&examples.join(name))
                .and_then(|s| s.sim())
                .unwrap();
            let page = crate::sim::board_page(&config).unwrap();
            let assignments = page_assignments(&page);
            assert_eq!(assignments.len(), SLOTS, "{name}");
            let (items, values) =
                check_assignments(&a2l, &assignments).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(items.len(), a2l.characteristics.len(), "{name}");
            let rate = assignments
                .iter()
                .find(|(n, _)| n == "sample_rate")
                .unwrap()
                .1;
            assert_eq!(rate, config.run.sample_rate_hz, "{name}");
            // Each slot's item sits at its slot's address.
            for (k, item) in items.iter().enumerate() {
                assert_eq!(
                    item.address,
                    0x2000_8000 + 4 * k as u32,
                    "{name}: {}",
                    item.name
                );
            }
            assert_eq!(values.len(), SLOTS);
        }
    }
}
