//! Serde helpers for `Option` fields written `n/a` when missing (BIDS).

use serde::{Deserialize, Deserializer, Serializer};

/// A value that can stand in an `n/a`-able TSV field.
pub trait NaValue: Sized {
    /// The field text.
    fn to_field(&self) -> String;
    /// Parses the field text.
    fn from_field(s: &str) -> Result<Self, String>;
}

impl NaValue for f64 {
    fn to_field(&self) -> String {
        // Debug: shortest round-trip form, exponent for tiny/huge values.
        format!("{self:?}")
    }
    fn from_field(s: &str) -> Result<Self, String> {
        s.parse()
            .map_err(|_| format!("{s:?} is not a number or {}", super::NA))
    }
}

impl NaValue for bool {
    fn to_field(&self) -> String {
        self.to_string()
    }
    fn from_field(s: &str) -> Result<Self, String> {
        s.parse()
            .map_err(|_| format!("{s:?} is not true, false or {}", super::NA))
    }
}

macro_rules! na_int {
    ($($t:ty),*) => {$(
        impl NaValue for $t {
            fn to_field(&self) -> String {
                self.to_string()
            }
            fn from_field(s: &str) -> Result<Self, String> {
                s.parse().map_err(|_| {
                    format!("{s:?} is not a non-negative integer or {}", super::NA)
                })
            }
        }
    )*};
}
na_int!(u32, u64, usize);

/// Text (a field written `n/a` or left empty reads back as `None`, so
/// a `Some` of either does not round-trip).
impl NaValue for String {
    fn to_field(&self) -> String {
        self.clone()
    }
    fn from_field(s: &str) -> Result<Self, String> {
        Ok(s.to_string())
    }
}

/// `None` → `n/a`.
pub fn serialize<T: NaValue, S: Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(x) => s.serialize_str(&x.to_field()),
        None => s.serialize_str(super::NA),
    }
}

/// `n/a` or an empty field → `None`.
pub fn deserialize<'de, T: NaValue, D: Deserializer<'de>>(d: D) -> Result<Option<T>, D::Error> {
    let s = String::deserialize(d)?;
    if s == super::NA || s.is_empty() {
        Ok(None)
    } else {
        T::from_field(&s)
            .map(Some)
            .map_err(serde::de::Error::custom)
    }
}

/// A flag column added after a file's first version: written `true` or
/// `false`; `n/a` (what an upgraded file holds in its earlier rows) or an
/// empty field reads as `false`, the flag's meaning before the column
/// existed.
pub mod flag {
    use super::NaValue;
    use serde::{Deserialize, Deserializer, Serializer};

    /// `true` / `false`.
    pub fn serialize<S: Serializer>(v: &bool, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&v.to_field())
    }

    /// `true` / `false`; `n/a` or empty → `false`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
        let s = String::deserialize(d)?;
        if s == super::super::NA || s.is_empty() {
            Ok(false)
        } else {
            bool::from_field(&s).map_err(serde::de::Error::custom)
        }
    }
}
