//! Reading and writing A2L items by value: contiguous items in one transfer, writes checked
//! on the host first (finite, within the A2L limits, representable) and sent as one change
//! per contiguous run, then read back.

use mil_can::Transport;

use crate::a2l::Item;
use crate::error::{Error, Result};
use crate::master::Master;

/// One parameter as changed.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// The parameter.
    pub name: String,
    /// Its value before (physical unit).
    pub old: f64,
    /// Its value after, as read back from the board.
    pub new: f64,
    /// The unit.
    pub unit: String,
}

/// Items that lie back to back in memory (same extension), in address order: indices into
/// the list given. Each group stays within `max_bytes` where a single item allows.
///
/// # Errors
/// Two items overlap (the same item twice included).
pub fn contiguous_groups(items: &[&Item], max_bytes: usize) -> Result<Vec<Vec<usize>>> {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&i| (items[i].extension, items[i].address));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut end: Option<(u8, u64)> = None;
    let mut bytes = 0usize;
    for i in order {
        let it = items[i];
        let start = u64::from(it.address);
        if let Some((ext, e)) = end {
            if ext == it.extension && start < e {
                let other = groups
                    .last()
                    .and_then(|g| g.last())
                    .map_or("", |&j| items[j].name.as_str());
                return Err(Error::UnsupportedItem {
                    name: it.name.clone(),
                    why: if other == it.name {
                        "given twice".to_string()
                    } else {
                        format!("overlaps {other} in memory")
                    },
                });
            }
        }
        let joins = end == Some((it.extension, start)) && bytes + it.size() <= max_bytes;
        match groups.last_mut() {
            Some(g) if joins => {
                g.push(i);
                bytes += it.size();
            }
            _ => {
                groups.push(vec![i]);
                bytes = it.size();
            }
        }
        end = Some((it.extension, start + it.size() as u64));
    }
    Ok(groups)
}

impl<T: Transport> Master<T> {
    /// The physical values of `items` on the XCP page, in the order given (contiguous items
    /// in one upload).
    ///
    /// # Errors
    /// Not connected, timeout, a negative response, an unsupported conversion.
    pub fn read_items(&mut self, items: &[&Item]) -> Result<Vec<f64>> {
        let mut values = vec![0.0; items.len()];
        for group in contiguous_groups(items, usize::MAX)? {
            let first = items[group[0]];
            let len: usize = group.iter().map(|&i| items[i].size()).sum();
            let bytes = self.upload(first.address, first.extension, len)?;
            let mut at = 0;
            for &i in &group {
                let n = items[i].size();
                values[i] = items[i].decode(&bytes[at..at + n])?;
                at += n;
            }
        }
        Ok(values)
    }

    /// Writes `values` (physical) into `items`: every value is checked on the host first
    /// ([`Item::encode_checked`]) and nothing is sent when one fails; then each run of
    /// contiguous items goes to the board as one change (one DOWNLOAD or block), runs one
    /// after another. Returns old and new (read back) values. CAL/PAG must be unlocked.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] before anything is sent; [`Error::Refused`] when the board
    /// refuses a change (that change is not applied; earlier runs stay); timeout etc.
    pub fn write_items(&mut self, items: &[&Item], values: &[f64]) -> Result<Vec<Change>> {
        self.write(items, values, false)
    }

    /// As [`Master::write_items`], but all items must form ONE change the board validates
    /// as a whole (contiguous, within one block): refused before anything is sent otherwise.
    ///
    /// # Errors
    /// As [`Master::write_items`]; [`Error::Unsupported`] when the items are not one run.
    pub fn write_items_as_one_change(
        &mut self,
        items: &[&Item],
        values: &[f64],
    ) -> Result<Vec<Change>> {
        self.write(items, values, true)
    }

    fn write(&mut self, items: &[&Item], values: &[f64], one: bool) -> Result<Vec<Change>> {
        if items.len() != values.len() {
            return Err(Error::Unsupported(format!(
                "{} items but {} values",
                items.len(),
                values.len()
            )));
        }
        let max = self.session().ok_or(Error::NotConnected)?.max_one_change();
        let encoded: Vec<Vec<u8>> = items
            .iter()
            .zip(values)
            .map(|(it, &v)| it.encode_checked(v))
            .collect::<Result<_>>()?;
        let groups = contiguous_groups(items, max)?;
        if one && groups.len() > 1 {
            let total: usize = items.iter().map(|i| i.size()).sum();
            return Err(Error::Unsupported(format!(
                "{} cannot be written as one change: {}",
                names(items, &(0..items.len()).collect::<Vec<_>>()),
                if total > max {
                    format!("{total} bytes, the board takes at most {max} in one block")
                } else {
                    "they are not contiguous in memory".to_string()
                }
            )));
        }
        let old = self.read_items(items)?;
        let mut applied: Vec<String> = Vec::new();
        for group in &groups {
            let first = items[group[0]];
            let data: Vec<u8> = group.iter().flat_map(|&i| encoded[i].clone()).collect();
            if let Err(e) = self.download_one_change(first.address, first.extension, &data) {
                return Err(match e {
                    e @ Error::Negative { .. } => Error::Refused {
                        names: group
                            .iter()
                            .map(|&i| format!("{} = {}", items[i].name, values[i]))
                            .collect::<Vec<_>>()
                            .join(", "),
                        reason: Box::new(e),
                        applied,
                    },
                    other => other,
                });
            }
            applied.extend(group.iter().map(|&i| items[i].name.clone()));
        }
        let new = self.read_items(items)?;
        Ok(items
            .iter()
            .zip(old.iter().zip(&new))
            .map(|(it, (&o, &n))| Change {
                name: it.name.clone(),
                old: o,
                new: n,
                unit: it.unit_or_dash().to_string(),
            })
            .collect())
    }
}

fn names(items: &[&Item], idx: &[usize]) -> String {
    idx.iter()
        .map(|&i| items[i].name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::a2l::{Conversion, DataType, Endian};

    fn item(name: &str, address: u32) -> Item {
        Item {
            name: name.into(),
            description: String::new(),
            address,
            extension: 0,
            datatype: DataType::F32,
            endian: Endian::Little,
            conversion: Conversion::Identical,
            min: 0.0,
            max: 1.0,
            unit: String::new(),
        }
    }

    #[test]
    fn runs_of_adjacent_items_group_in_address_order() {
        let a = item("a", 0x100);
        let b = item("b", 0x104);
        let c = item("c", 0x10C);
        let d = item("d", 0x108);
        let groups = contiguous_groups(&[&c, &a, &b], 252).unwrap();
        assert_eq!(groups, vec![vec![1, 2], vec![0]]);
        let groups = contiguous_groups(&[&c, &a, &b, &d], 252).unwrap();
        assert_eq!(groups, vec![vec![1, 2, 3, 0]]);
        // A block limit of 8 bytes cuts the run.
        let groups = contiguous_groups(&[&c, &a, &b, &d], 8).unwrap();
        assert_eq!(groups, vec![vec![1, 2], vec![3, 0]]);
        let twice = contiguous_groups(&[&a, &a], 252).unwrap_err();
        assert!(twice.to_string().contains("given twice"), "{twice}");
        let e = item("e", 0x102);
        assert!(contiguous_groups(&[&a, &e], 252)
            .unwrap_err()
            .to_string()
            .contains("overlaps a"));
    }
}
