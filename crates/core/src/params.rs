//! Structure parameters, declared once next to the fields they describe.
//!
//! A structure crate writes its params struct with [`params!`](crate::params!): each field
//! carries its doc (citing the paper's symbol), its type, its default and its kind with range.
//! The macro derives from that one declaration the struct, its `Default`, its parameter table
//! ([`Params::SPECS`], what `trace-bench list` prints and configs are checked against), and the
//! conversion from a checked [`ParamSet`] ([`Params::from_set`]; a missing or mistyped value is
//! an error, never a silently chosen fallback). Enumerated parameters are enums declared with
//! [`choice!`](crate::choice!), which lists their config names once.
//!
//! The harness turns a config's `params` table into [`ParamSet`]s (sweeps as cartesian products)
//! against these specs; this module knows no TOML.

use std::fmt;

/// The type and range of a parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamKind {
    /// An integer in `min..=max`.
    Int {
        /// Smallest allowed value.
        min: i64,
        /// Largest allowed value.
        max: i64,
    },
    /// A number in `min..=max`.
    Float {
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// `true` or `false`.
    Bool,
    /// One of the listed names.
    Choice(&'static [&'static str]),
}

/// One declared parameter.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    /// Config key (the field name).
    pub name: &'static str,
    /// Its type and range, against which config values are checked.
    pub kind: ParamKind,
    /// One line (the field's doc comment): meaning, paper symbol and section.
    pub doc: &'static str,
}

impl ParamSpec {
    /// The doc as one trimmed line.
    pub fn doc_line(&self) -> String {
        self.doc.split_whitespace().collect::<Vec<_>>().join(" ")
    }

    /// Check `v` against the kind's range or list; `Err` says why not.
    pub fn check(&self, v: &ParamValue) -> Result<(), String> {
        match (self.kind, v) {
            (ParamKind::Int { min, max }, ParamValue::Int(i)) => {
                if *i < min || *i > max {
                    return Err(format!("{i} is out of range {min}..={max}"));
                }
            }
            (ParamKind::Float { min, max }, ParamValue::Float(x)) => {
                if !(*x >= min && *x <= max) {
                    return Err(format!("{x} is out of range {min}..={max}"));
                }
            }
            (ParamKind::Bool, ParamValue::Bool(_)) => {}
            (ParamKind::Choice(options), ParamValue::Str(s)) => {
                if !options.contains(&s.as_str()) {
                    return Err(format!("`{s}` is not one of {}", options.join(", ")));
                }
            }
            (kind, v) => return Err(format!("expected {}, found {v}", kind.describe())),
        }
        Ok(())
    }
}

impl ParamKind {
    /// What a value of this kind looks like, for error messages and listings.
    pub fn describe(&self) -> String {
        match self {
            ParamKind::Int { min, max } => format!("an integer in {min}..={max}"),
            ParamKind::Float { min, max } => format!("a number in {min}..={max}"),
            ParamKind::Bool => "true or false".into(),
            ParamKind::Choice(o) => format!("one of \"{}\"", o.join("\", \"")),
        }
    }
}

/// A parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// An integer (`Int` parameters).
    Int(i64),
    /// A number (`Float` parameters).
    Float(f64),
    /// `true` or `false` (`Bool` parameters).
    Bool(bool),
    /// A name (`Choice` parameters).
    Str(String),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Str(v) => write!(f, "{v}"),
        }
    }
}

/// Why a [`ParamSet`] does not convert to a params struct.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// A declared parameter has no value in the set.
    #[error("parameter `{0}` is missing")]
    Missing(&'static str),
    /// A value of the wrong type or out of its range.
    #[error("parameter `{name}`: {message}")]
    Invalid {
        /// The parameter's config name.
        name: &'static str,
        /// What is wrong with its value.
        message: String,
    },
}

/// A full set of parameter values, in spec order.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParamSet(pub Vec<(&'static str, ParamValue)>);

impl ParamSet {
    /// The value of `name`, if the set has one.
    pub fn get(&self, name: &str) -> Option<&ParamValue> {
        self.0.iter().find(|(n, _)| *n == name).map(|(_, v)| v)
    }

    /// Take the value of `name` as `T` (for [`Params::from_set`]).
    pub fn take<T: ParamType>(&self, name: &'static str) -> Result<T, ParamError> {
        let v = self.get(name).ok_or(ParamError::Missing(name))?;
        T::from_value(v).map_err(|message| ParamError::Invalid { name, message })
    }
}

impl fmt::Display for ParamSet {
    /// `name=value;name=value` in spec order (the `params` column).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (n, v)) in self.0.iter().enumerate() {
            if i > 0 {
                write!(f, ";")?;
            }
            write!(f, "{n}={v}")?;
        }
        Ok(())
    }
}

/// A Rust type a parameter field may have.
pub trait ParamType: Sized {
    /// Convert a checked value; `Err` for a value of another type or out of the type's range.
    fn from_value(v: &ParamValue) -> Result<Self, String>;
    /// The value as a config writes it.
    fn to_value(&self) -> ParamValue;
}

impl ParamType for u32 {
    fn from_value(v: &ParamValue) -> Result<Self, String> {
        match v {
            ParamValue::Int(i) => u32::try_from(*i).map_err(|_| format!("{i} does not fit u32")),
            v => Err(format!("expected an integer, found {v}")),
        }
    }
    fn to_value(&self) -> ParamValue {
        ParamValue::Int(*self as i64)
    }
}

impl ParamType for f32 {
    fn from_value(v: &ParamValue) -> Result<Self, String> {
        match v {
            ParamValue::Float(x) => Ok(*x as f32),
            ParamValue::Int(i) => Ok(*i as f32),
            v => Err(format!("expected a number, found {v}")),
        }
    }
    fn to_value(&self) -> ParamValue {
        // The shortest decimal that reads back as this f32 (`0.3`, not `0.30000001192092896`).
        ParamValue::Float(self.to_string().parse().unwrap_or(*self as f64))
    }
}

impl ParamType for bool {
    fn from_value(v: &ParamValue) -> Result<Self, String> {
        match v {
            ParamValue::Bool(b) => Ok(*b),
            v => Err(format!("expected true or false, found {v}")),
        }
    }
    fn to_value(&self) -> ParamValue {
        ParamValue::Bool(*self)
    }
}

/// A params struct: its table, defaults and conversion. Implemented by [`params!`](crate::params!).
pub trait Params: Sized + Default {
    /// The parameter table, in field order.
    const SPECS: &'static [ParamSpec];
    /// Convert a checked set holding every spec's value.
    fn from_set(set: &ParamSet) -> Result<Self, ParamError>;
    /// This value as a set (the defaults: `Self::default().to_set()`).
    fn to_set(&self) -> ParamSet;

    /// Every value against its range or list in the table ([`Params::SPECS`]): the ranges are
    /// declared once, with the fields, and checked here, never written out again.
    fn check_ranges(&self) -> Result<(), ParamError> {
        for ((name, value), spec) in self.to_set().0.iter().zip(Self::SPECS) {
            spec.check(value)
                .map_err(|message| ParamError::Invalid { name, message })?;
        }
        Ok(())
    }
}

/// Rules across a structure's parameters that each one's range in the table cannot express
/// (R-tree `m ≤ M/2`, BVH `width` of 2, 4 or 8, `min_leaf ≤ max_leaf`): declared once, beside
/// the parameters, and checked with the rest of a config before any work starts
/// ([`crate::Family::with_rules`]); the builder checks them again.
pub trait ParamRules: Params {
    /// `Err(message)` when the values do not go together (the ranges are checked already);
    /// none by default.
    fn rules(&self) -> Result<(), String> {
        Ok(())
    }

    /// What a builder checks before it builds: the ranges of the table, then the rules; the
    /// error names the structure `what`.
    fn check_all(&self, what: &str) -> Result<(), crate::AccelError> {
        self.check_ranges()
            .map_err(|e| e.to_string())
            .and_then(|()| self.rules())
            .map_err(|e| crate::AccelError::Params(format!("{what}: {e}")))
    }
}

/// [`ParamRules::rules`] of a checked set (a function pointer for [`crate::Family`]).
pub fn rules_of<P: ParamRules>(set: &ParamSet) -> Result<(), String> {
    P::from_set(set).map_err(|e| e.to_string())?.rules()
}

/// No rules beyond the ranges (the default of [`crate::Family`]).
pub fn no_rules(_: &ParamSet) -> Result<(), String> {
    Ok(())
}

/// The default parameter set of `P` (a function pointer for [`crate::Family`]).
pub fn defaults_of<P: Params>() -> ParamSet {
    P::default().to_set()
}

/// Declare a params struct: fields with their doc, type, default and [`ParamKind`], from which
/// the struct, `Default` and [`Params`] are derived.
///
/// A field marked `@flatten` (type, default, no kind) is a params struct of its own, a group
/// declared once and composed by several structures (the kd-tree's SAH parameters in the
/// kd-tree, sparse boxes and multi-kd-tree): its entries stand in this table at the field's
/// place, under their own names, so a config and the `params` column see one flat table.
///
/// ```
/// use tb_core::params::{ParamKind, Params};
/// tb_core::params! {
///     /// Costs shared by several structures.
///     #[derive(Clone, Copy, Debug, PartialEq)]
///     pub struct Costs {
///         /// Traversal cost C_trav.
///         c_trav: f32 = 1.0, ParamKind::Float { min: 1e-6, max: 1e6 };
///     }
/// }
/// tb_core::params! {
///     /// Example parameters.
///     #[derive(Clone, Copy, Debug, PartialEq)]
///     pub struct Example {
///         /// Bins per axis (Wald 2007).
///         bins: u32 = 16, ParamKind::Int { min: 2, max: 256 };
///         @flatten
///         costs: Costs = Costs { c_trav: 2.0 };
///     }
/// }
/// assert_eq!(Example::SPECS[1].name, "c_trav");
/// assert_eq!(Example::default().to_set().to_string(), "bins=16;c_trav=2");
/// assert_eq!(Example::from_set(&Example::default().to_set()), Ok(Example::default()));
/// ```
#[macro_export]
macro_rules! params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $(@$flatten:ident)?
                $field:ident : $ty:ty = $default:expr $(, $kind:expr)?;
            )*
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        impl ::core::default::Default for $name {
            fn default() -> Self {
                Self { $( $field: $default, )* }
            }
        }

        impl $crate::params::Params for $name {
            const SPECS: &'static [$crate::params::ParamSpec] = {
                const PARTS: &[&[$crate::params::ParamSpec]] = &[$(
                    $crate::__param_part!(specs $($flatten)? ; $field; $ty; $($kind)?; $($doc),*),
                )*];
                const N: usize = $crate::params::specs_len(PARTS);
                const ALL: [$crate::params::ParamSpec; N] = $crate::params::concat_specs(PARTS);
                &ALL
            };

            fn from_set(
                set: &$crate::params::ParamSet,
            ) -> ::core::result::Result<Self, $crate::params::ParamError> {
                let _ = set;
                Ok(Self { $( $field: $crate::__param_part!(take $($flatten)? ; set; $field; $ty), )* })
            }

            #[allow(unused_mut, clippy::vec_init_then_push)]
            fn to_set(&self) -> $crate::params::ParamSet {
                let mut out = ::std::vec::Vec::new();
                $( $crate::__param_part!(put $($flatten)? ; out; self.$field; $field); )*
                $crate::params::ParamSet(out)
            }
        }
    };
}

/// The parts [`params!`](crate::params!) writes per field, plain or `@flatten`.
#[doc(hidden)]
#[macro_export]
macro_rules! __param_part {
    (specs ; $field:ident; $ty:ty; $kind:expr; $($doc:literal),*) => {
        &[$crate::params::ParamSpec {
            name: stringify!($field),
            kind: $kind,
            doc: concat!($($doc),*),
        }]
    };
    (specs flatten ; $field:ident; $ty:ty; ; $($doc:literal),*) => {
        <$ty as $crate::params::Params>::SPECS
    };
    (take ; $set:ident; $field:ident; $ty:ty) => {
        $set.take(stringify!($field))?
    };
    (take flatten ; $set:ident; $field:ident; $ty:ty) => {
        <$ty as $crate::params::Params>::from_set($set)?
    };
    (put ; $out:ident; $value:expr; $field:ident) => {
        $out.push((stringify!($field), $crate::params::ParamType::to_value(&$value)))
    };
    (put flatten ; $out:ident; $value:expr; $field:ident) => {
        $out.extend($crate::params::Params::to_set(&$value).0)
    };
}

/// The number of entries of the parts of a table (for [`params!`](crate::params!)).
#[doc(hidden)]
pub const fn specs_len(parts: &[&[ParamSpec]]) -> usize {
    let (mut n, mut i) = (0, 0);
    while i < parts.len() {
        n += parts[i].len();
        i += 1;
    }
    n
}

/// The parts of a table, one after the other (for [`params!`](crate::params!)).
#[doc(hidden)]
pub const fn concat_specs<const N: usize>(parts: &[&[ParamSpec]]) -> [ParamSpec; N] {
    const EMPTY: ParamSpec = ParamSpec {
        name: "",
        kind: ParamKind::Bool,
        doc: "",
    };
    let mut out = [EMPTY; N];
    let (mut k, mut i) = (0, 0);
    while i < parts.len() {
        let mut j = 0;
        while j < parts[i].len() {
            out[k] = parts[i][j];
            k += 1;
            j += 1;
        }
        i += 1;
    }
    assert!(k == N, "the parts do not fill the table");
    out
}

/// Declare an enumerated parameter: a fieldless enum whose variants each have a config name,
/// with `NAMES` (for [`ParamKind::Choice`]), `name()`, `from_name()` and [`ParamType`].
///
/// ```
/// tb_core::choice! {
///     /// How to split.
///     #[derive(Clone, Copy, Debug, PartialEq, Eq)]
///     pub enum Split { Sah = "sah", Median = "median" }
/// }
/// assert_eq!(Split::NAMES, &["sah", "median"]);
/// assert_eq!(Split::from_name("median"), Some(Split::Median));
/// ```
#[macro_export]
macro_rules! choice {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[doc = $doc:literal])* $variant:ident = $cfg:literal ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis enum $name {
            $( $(#[doc = $doc])* $variant, )*
        }

        impl $name {
            /// The config names, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($cfg),*];

            /// Every variant, in declaration order.
            #[allow(dead_code)]
            pub const ALL: &'static [Self] = &[$(Self::$variant),*];

            /// The config name.
            pub fn name(&self) -> &'static str {
                match self { $( Self::$variant => $cfg, )* }
            }

            /// The variant with config name `s`.
            pub fn from_name(s: &str) -> Option<Self> {
                match s { $( $cfg => Some(Self::$variant), )* _ => None }
            }
        }

        impl $crate::__serde::Serialize for $name {
            fn serialize<S: $crate::__serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        impl<'de> $crate::__serde::Deserialize<'de> for $name {
            fn deserialize<D: $crate::__serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = <String as $crate::__serde::Deserialize>::deserialize(d)?;
                Self::from_name(&s).ok_or_else(|| {
                    <D::Error as $crate::__serde::de::Error>::custom(format!(
                        "`{s}` is not one of {}",
                        Self::NAMES.join(", ")
                    ))
                })
            }
        }

        impl $crate::params::ParamType for $name {
            fn from_value(v: &$crate::params::ParamValue) -> Result<Self, String> {
                match v {
                    $crate::params::ParamValue::Str(s) => Self::from_name(s).ok_or_else(|| {
                        format!("`{s}` is not one of {}", Self::NAMES.join(", "))
                    }),
                    v => Err(format!("expected a name, found {v}")),
                }
            }
            fn to_value(&self) -> $crate::params::ParamValue {
                $crate::params::ParamValue::Str(self.name().to_string())
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::choice! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        enum Split { Sah = "sah", Median = "median" }
    }

    crate::params! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        struct P {
            /// Bins
            /// per axis.
            bins: u32 = 16, ParamKind::Int { min: 2, max: 256 };
            share: f32 = 0.3, ParamKind::Float { min: 0.0, max: 1.0 };
            split: Split = Split::Sah, ParamKind::Choice(Split::NAMES);
            on: bool = true, ParamKind::Bool;
        }
    }

    #[test]
    fn one_declaration_gives_table_defaults_and_conversion() {
        assert_eq!(P::SPECS.len(), 4);
        assert_eq!(P::SPECS[0].doc_line(), "Bins per axis.");
        let d = P::default().to_set();
        assert_eq!(d.to_string(), "bins=16;share=0.3;split=sah;on=true");
        assert_eq!(P::from_set(&d), Ok(P::default()));
        let mut s = d.clone();
        s.0[2].1 = ParamValue::Str("median".into());
        assert_eq!(P::from_set(&s).unwrap().split, Split::Median);
    }

    crate::params! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        struct Outer {
            first: u32 = 1, ParamKind::Int { min: 0, max: 9 };
            @flatten
            inner: P = P { bins: 8, ..P::default() };
            last: bool = false, ParamKind::Bool;
        }
    }

    #[test]
    fn a_flattened_group_stands_in_the_table_at_its_place() {
        let names: Vec<&str> = Outer::SPECS.iter().map(|s| s.name).collect();
        assert_eq!(names, ["first", "bins", "share", "split", "on", "last"]);
        assert_eq!(Outer::SPECS[1].doc_line(), "Bins per axis.");
        let d = Outer::default().to_set();
        assert_eq!(
            d.to_string(),
            "first=1;bins=8;share=0.3;split=sah;on=true;last=false"
        );
        assert_eq!(Outer::from_set(&d), Ok(Outer::default()));
        let mut s = d.clone();
        s.0[1].1 = ParamValue::Int(1);
        let bad = Outer::from_set(&s).unwrap();
        assert_eq!(bad.inner.bins, 1);
        assert!(matches!(
            bad.check_ranges(),
            Err(ParamError::Invalid { name: "bins", .. })
        ));
        assert_eq!(Outer::default().check_ranges(), Ok(()));
    }

    #[test]
    fn conversion_has_no_fallback() {
        let mut s = P::default().to_set();
        s.0[2].1 = ParamValue::Str("other".into());
        assert!(matches!(
            P::from_set(&s),
            Err(ParamError::Invalid { name: "split", .. })
        ));
        s.0.remove(0);
        assert_eq!(P::from_set(&s), Err(ParamError::Missing("bins")));
        let bad = ParamSet(vec![("bins", ParamValue::Int(-1))]);
        assert!(bad.take::<u32>("bins").is_err());
    }

    #[test]
    fn specs_check_ranges_and_types() {
        let s = &P::SPECS[0];
        assert!(s.check(&ParamValue::Int(16)).is_ok());
        assert!(s
            .check(&ParamValue::Int(1))
            .unwrap_err()
            .contains("out of range"));
        assert!(s
            .check(&ParamValue::Bool(true))
            .unwrap_err()
            .contains("expected"));
        assert!(P::SPECS[2]
            .check(&ParamValue::Str("x".into()))
            .unwrap_err()
            .contains("not one of"));
    }
}
