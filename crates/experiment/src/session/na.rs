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
