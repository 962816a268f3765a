//! ROS 2 type descriptions and their REP-2016 type hashes (`RIHS01_<64 hex>`).
//!
//! Why computed and not pasted: a hash copied from somewhere else cannot be
//! checked, and the hash is part of every rmw_zenoh key expression, so one
//! wrong digit makes a topic silently invisible. The hash is the SHA-256 of
//! the type's description as REP-2016 and `rosidl_generator_type_description`
//! define it: the JSON of `{"type_description": …, "referenced_type_descriptions": […]}`
//! with each field's name and type (type id, capacity, string capacity,
//! nested type name) and no default values or comments, the referenced types
//! sorted by name, written as Python's `json.dumps` writes it (`", "` and
//! `": "` separators). rmw_zenoh's own example (`std_msgs/msg/String` →
//! `RIHS01_df668c74…1a18`) and PyPI `rosbags` (`hash_rihs01`) check it in the
//! tests.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

/// A primitive field type, with its REP-2016 type id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Primitive {
    /// `int8`
    Int8 = 2,
    /// `uint8`
    Uint8 = 3,
    /// `int16`
    Int16 = 4,
    /// `uint16`
    Uint16 = 5,
    /// `int32`
    Int32 = 6,
    /// `uint32`
    Uint32 = 7,
    /// `int64`
    Int64 = 8,
    /// `uint64`
    Uint64 = 9,
    /// `float32`
    Float32 = 10,
    /// `float64`
    Float64 = 11,
    /// `char`
    Char = 13,
    /// `bool`
    Bool = 15,
    /// `byte`
    Byte = 16,
    /// `string` (unbounded)
    String = 17,
}

impl Primitive {
    /// Its name in a `.msg` file.
    pub const fn msg_name(self) -> &'static str {
        match self {
            Self::Int8 => "int8",
            Self::Uint8 => "uint8",
            Self::Int16 => "int16",
            Self::Uint16 => "uint16",
            Self::Int32 => "int32",
            Self::Uint32 => "uint32",
            Self::Int64 => "int64",
            Self::Uint64 => "uint64",
            Self::Float32 => "float32",
            Self::Float64 => "float64",
            Self::Char => "char",
            Self::Bool => "bool",
            Self::Byte => "byte",
            Self::String => "string",
        }
    }
}

/// `pkg/msg/Type` → `pkg/Type`, as a `.msg` file names a nested type.
fn short_name(full: &str) -> String {
    match full.split('/').collect::<Vec<_>>()[..] {
        [pkg, _, name] => format!("{pkg}/{name}"),
        _ => full.to_string(),
    }
}

/// What one element of a field is.
#[derive(Debug, Clone, Copy)]
pub enum Base {
    /// A primitive or an unbounded string.
    Primitive(Primitive),
    /// Another message type.
    Nested(&'static TypeDescription),
}

/// How many elements a field holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// Exactly one.
    One,
    /// A fixed-size array `T[n]`.
    Array(u64),
    /// A bounded sequence `T[<=n]`.
    BoundedSequence(u64),
    /// An unbounded sequence `T[]`.
    Sequence,
}

/// One field of a message type.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    /// The field's name.
    pub name: &'static str,
    /// Its element type.
    pub base: Base,
    /// How many elements.
    pub arity: Arity,
}

impl Field {
    /// A single primitive field.
    pub const fn prim(name: &'static str, p: Primitive) -> Self {
        Self { name, base: Base::Primitive(p), arity: Arity::One }
    }

    /// A single nested field.
    pub const fn nested(name: &'static str, t: &'static TypeDescription) -> Self {
        Self { name, base: Base::Nested(t), arity: Arity::One }
    }

    /// An unbounded sequence of a nested type.
    pub const fn sequence(name: &'static str, t: &'static TypeDescription) -> Self {
        Self { name, base: Base::Nested(t), arity: Arity::Sequence }
    }

    /// An unbounded sequence of a primitive, `T[]`.
    pub const fn prim_sequence(name: &'static str, p: Primitive) -> Self {
        Self { name, base: Base::Primitive(p), arity: Arity::Sequence }
    }

    /// A fixed-size array of a primitive, `T[n]`.
    pub const fn array(name: &'static str, p: Primitive, n: u64) -> Self {
        Self { name, base: Base::Primitive(p), arity: Arity::Array(n) }
    }

    /// A bounded sequence of a nested type, `T[<=n]`.
    pub const fn bounded(name: &'static str, t: &'static TypeDescription, n: u64) -> Self {
        Self { name, base: Base::Nested(t), arity: Arity::BoundedSequence(n) }
    }

    /// The REP-2016 type id: the element's id plus 48 (array), 96 (bounded
    /// sequence) or 144 (unbounded sequence); a nested type's element id is 1.
    pub fn type_id(&self) -> u32 {
        let element = match self.base {
            Base::Primitive(p) => p as u32,
            Base::Nested(_) => 1,
        };
        element
            + match self.arity {
                Arity::One => 0,
                Arity::Array(_) => 48,
                Arity::BoundedSequence(_) => 96,
                Arity::Sequence => 144,
            }
    }

    fn capacity(&self) -> u64 {
        match self.arity {
            Arity::Array(n) | Arity::BoundedSequence(n) => n,
            Arity::One | Arity::Sequence => 0,
        }
    }
}

/// A message type: its full name (`pkg/msg/Name`) and its fields in order.
#[derive(Debug)]
pub struct TypeDescription {
    /// `geometry_msgs/msg/PoseStamped`.
    pub name: &'static str,
    /// The fields; an empty message has none (its hash and CDR hold the
    /// `uint8 structure_needs_at_least_one_member` rosidl adds).
    pub fields: &'static [Field],
}

/// The field rosidl gives a message without fields.
const PLACEHOLDER: [Field; 1] = [Field::prim("structure_needs_at_least_one_member", Primitive::Uint8)];

impl TypeDescription {
    fn effective_fields(&self) -> &[Field] {
        if self.fields.is_empty() {
            &PLACEHOLDER
        } else {
            self.fields
        }
    }

    /// Every type this one refers to, directly or not, by name.
    pub fn referenced(&'static self) -> BTreeMap<&'static str, &'static TypeDescription> {
        let mut found = BTreeMap::new();
        let mut todo = vec![self];
        while let Some(t) = todo.pop() {
            for field in t.fields {
                if let Base::Nested(n) = field.base {
                    if found.insert(n.name, n).is_none() {
                        todo.push(n);
                    }
                }
            }
        }
        found
    }

    /// The JSON REP-2016 hashes, byte for byte.
    pub fn hash_json(&'static self) -> String {
        let mut out = String::from("{\"type_description\": ");
        self.write_json(&mut out);
        out.push_str(", \"referenced_type_descriptions\": [");
        for (i, t) in self.referenced().values().enumerate() {
            if i > 0 {
                out.push_str(", ");
            }
            t.write_json(&mut out);
        }
        out.push_str("]}");
        out
    }

    fn write_json(&self, out: &mut String) {
        let _ = write!(out, "{{\"type_name\": \"{}\", \"fields\": [", self.name);
        for (i, f) in self.effective_fields().iter().enumerate() {
            let nested = match f.base {
                Base::Nested(n) => n.name,
                Base::Primitive(_) => "",
            };
            let _ = write!(
                out,
                "{}{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": 0, \"nested_type_name\": \"{}\"}}}}",
                if i > 0 { ", " } else { "" },
                f.name,
                f.type_id(),
                f.capacity(),
                nested
            );
        }
        out.push_str("]}");
    }

    /// The type's `.msg` text as rosidl reads it: one `type name` line per
    /// field (no constants, no comments), nested types as `pkg/Type`.
    pub fn msg_text(&self) -> String {
        let mut out = String::new();
        for f in self.fields {
            let base = match f.base {
                Base::Primitive(p) => p.msg_name().to_string(),
                Base::Nested(n) => short_name(n.name),
            };
            let suffix = match f.arity {
                Arity::One => String::new(),
                Arity::Array(n) => format!("[{n}]"),
                Arity::BoundedSequence(n) => format!("[<={n}]"),
                Arity::Sequence => "[]".into(),
            };
            let _ = writeln!(out, "{base}{suffix} {}", f.name);
        }
        out
    }

    /// The `ros2msg` schema of an MCAP bag as rosbag2 writes it
    /// (`rosbag2_storage_mcap`'s `message_definition_cache.cpp`): the type's
    /// text, then each type it refers to as a line of 80 `=`, `MSG: pkg/Type`
    /// and its text.
    pub fn ros2msg(&'static self) -> String {
        let mut out = self.msg_text();
        for t in self.referenced().values() {
            let _ = write!(out, "\n{}\nMSG: {}\n{}", "=".repeat(80), short_name(t.name), t.msg_text());
        }
        out
    }

    /// The type hash, `RIHS01_` and 64 lowercase hex digits.
    pub fn rihs01(&'static self) -> String {
        let digest = Sha256::digest(self.hash_json().as_bytes());
        let mut out = String::from("RIHS01_");
        for b in digest {
            let _ = write!(out, "{b:02x}");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static STRING: TypeDescription =
        TypeDescription { name: "std_msgs/msg/String", fields: &[Field::prim("data", Primitive::String)] };

    /// rmw_zenoh's design document (docs/design): the key expression of `std_msgs/msg/String`.
    #[test]
    fn std_msgs_string_hashes_as_rmw_zenoh_documents() {
        assert_eq!(
            STRING.rihs01(),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
    }

    #[test]
    fn the_json_is_pythons_json_dumps_of_the_description() {
        assert_eq!(
            STRING.hash_json(),
            "{\"type_description\": {\"type_name\": \"std_msgs/msg/String\", \"fields\": [{\"name\": \"data\", \
             \"type\": {\"type_id\": 17, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}, \
             \"referenced_type_descriptions\": []}"
        );
    }

    #[test]
    fn type_ids_add_the_arity_offset() {
        let t = &STRING;
        let f = |arity| Field { name: "x", base: Base::Nested(t), arity };
        assert_eq!(
            [f(Arity::One), f(Arity::Array(3)), f(Arity::BoundedSequence(3)), f(Arity::Sequence)]
                .map(|f| f.type_id()),
            [1, 49, 97, 145]
        );
    }
}
