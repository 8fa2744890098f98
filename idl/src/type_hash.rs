//! REP-2011 type hashes (`RIHS01_<64 hex>`) of ROS 2 interface types, computed from their type
//! descriptions the way `rosidl_generator_type_description` does (ros2/rosidl,
//! `rosidl_generator_type_description/__init__.py`, `calculate_type_hash`):
//!
//! - the description is the type's own fields plus every type it references, transitively,
//!   sorted by type name (`referenced_type_descriptions`);
//! - each field is `name` and `type` = `type_id`, `capacity` (array size), `string_capacity`
//!   (bounded string size), `nested_type_name`, in that order (default values are left out of
//!   the hashed form);
//! - serialised as JSON with Python's `json.dumps(..., separators=(', ', ': '))` spacing, keys
//!   in the order above, ASCII only;
//! - SHA-256 of those bytes, hex, prefixed `RIHS01_`.
//!
//! ROS 2 Iron and later put the hash in each endpoint's USER_DATA as `typehash=RIHS01_...;`
//! ([`user_data`]). The descriptions themselves (one per type) live next to the wire types,
//! in [`crate::ros2`].

use sha2::{Digest, Sha256};

/// `type_description_interfaces/msg/FieldType` ids used by the types handgate speaks.
pub mod field_type {
    pub const NESTED_TYPE: u8 = 1;
    pub const UINT8: u8 = 3;
    pub const UINT16: u8 = 5;
    pub const INT32: u8 = 6;
    pub const UINT32: u8 = 7;
    pub const DOUBLE: u8 = 11;
    pub const BOOLEAN: u8 = 15;
    /// `byte` (`octet` in IDL).
    pub const BYTE: u8 = 16;
    pub const STRING: u8 = 17;
    pub const BOUNDED_STRING: u8 = 21;
    /// Added to a value type's id for a fixed-size array of it.
    pub const ARRAY: u8 = 48;
    /// Added to a value type's id for an unbounded sequence of it.
    pub const UNBOUNDED_SEQUENCE: u8 = 144;
}

/// One field of an individual type description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    pub name: &'static str,
    /// A [`field_type`] id (value type plus array / sequence offset).
    pub type_id: u8,
    /// Size of a fixed array, else 0.
    pub capacity: u64,
    /// Bound of a bounded string, else 0.
    pub string_capacity: u64,
    /// The nested type (of the field or of its elements), if any.
    pub nested: Option<&'static TypeDescription>,
}

impl Field {
    /// A field of a basic type (`type_id` from [`field_type`], offsets included).
    pub const fn basic(name: &'static str, type_id: u8) -> Self {
        Self {
            name,
            type_id,
            capacity: 0,
            string_capacity: 0,
            nested: None,
        }
    }

    /// A fixed-size array of a basic type.
    pub const fn array(name: &'static str, value_type_id: u8, size: u64) -> Self {
        Self {
            name,
            type_id: value_type_id + field_type::ARRAY,
            capacity: size,
            string_capacity: 0,
            nested: None,
        }
    }

    /// A bounded string (`string<=N`).
    pub const fn bounded_string(name: &'static str, bound: u64) -> Self {
        Self {
            name,
            type_id: field_type::BOUNDED_STRING,
            capacity: 0,
            string_capacity: bound,
            nested: None,
        }
    }

    /// A field of another message type.
    pub const fn nested(name: &'static str, ty: &'static TypeDescription) -> Self {
        Self {
            name,
            type_id: field_type::NESTED_TYPE,
            capacity: 0,
            string_capacity: 0,
            nested: Some(ty),
        }
    }

    /// An unbounded sequence of another message type (`Type[]`).
    pub const fn nested_sequence(name: &'static str, ty: &'static TypeDescription) -> Self {
        Self {
            name,
            type_id: field_type::NESTED_TYPE + field_type::UNBOUNDED_SEQUENCE,
            capacity: 0,
            string_capacity: 0,
            nested: Some(ty),
        }
    }
}

/// An individual type description: a ROS interface type name (`sensor_msgs/msg/JointState`)
/// and its fields in declaration order.
#[derive(Debug, PartialEq, Eq)]
pub struct TypeDescription {
    pub type_name: &'static str,
    pub fields: &'static [Field],
}

impl TypeDescription {
    /// Every type this one references, transitively, sorted by name, without duplicates.
    pub fn referenced(&self) -> Vec<&'static TypeDescription> {
        let mut out: Vec<&'static TypeDescription> = Vec::new();
        let mut queue: Vec<&'static TypeDescription> = self.fields.iter().filter_map(|f| f.nested).collect();
        while let Some(t) = queue.pop() {
            if out.iter().all(|o| o.type_name != t.type_name) {
                out.push(t);
                queue.extend(t.fields.iter().filter_map(|f| f.nested));
            }
        }
        out.sort_by_key(|t| t.type_name);
        out
    }

    /// The hashed representation: the JSON REP-2011 hashes (see the module docs).
    pub fn hashed_json(&self) -> String {
        let mut s = String::from("{\"type_description\": ");
        individual_json(self, &mut s);
        s.push_str(", \"referenced_type_descriptions\": [");
        for (i, t) in self.referenced().iter().enumerate() {
            if i > 0 {
                s.push_str(", ");
            }
            individual_json(t, &mut s);
        }
        s.push_str("]}");
        s
    }

    /// The type's `RIHS01_<64 hex>` hash.
    pub fn type_hash(&self) -> String {
        let digest = Sha256::digest(self.hashed_json().as_bytes());
        let mut out = String::from("RIHS01_");
        for b in digest {
            out.push_str(&format!("{b:02x}"));
        }
        out
    }
}

/// `typehash=RIHS01_...;`: the USER_DATA a ROS 2 (Iron and later) endpoint of this type
/// carries (rmw_dds_common `encode_type_hash_for_user_data_qos`).
pub fn user_data(t: &TypeDescription) -> Vec<u8> {
    format!("typehash={};", t.type_hash()).into_bytes()
}

fn json_str(v: &str, out: &mut String) {
    out.push('"');
    for c in v.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            c if (c as u32) < 0x20 || !c.is_ascii() => {
                // json.dumps(ensure_ascii=True): \uXXXX (UTF-16 units).
                let mut buf = [0u16; 2];
                for u in c.encode_utf16(&mut buf) {
                    out.push_str(&format!("\\u{u:04x}"));
                }
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

fn individual_json(t: &TypeDescription, out: &mut String) {
    out.push_str("{\"type_name\": ");
    json_str(t.type_name, out);
    out.push_str(", \"fields\": [");
    for (i, f) in t.fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str("{\"name\": ");
        json_str(f.name, out);
        out.push_str(&format!(
            ", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \"nested_type_name\": ",
            f.type_id, f.capacity, f.string_capacity
        ));
        json_str(f.nested.map_or("", |n| n.type_name), out);
        out.push_str("}}");
    }
    out.push_str("]}");
}

#[cfg(test)]
mod tests {
    use super::*;

    static LEAF: TypeDescription = TypeDescription {
        type_name: "pkg/msg/Leaf",
        fields: &[Field::basic("x", field_type::INT32)],
    };
    static MID: TypeDescription = TypeDescription {
        type_name: "pkg/msg/Mid",
        fields: &[Field::nested("leaf", &LEAF), Field::array("a", field_type::UINT8, 4)],
    };
    static TOP: TypeDescription = TypeDescription {
        type_name: "pkg/msg/Top",
        fields: &[
            Field::nested_sequence("mids", &MID),
            Field::nested("leaf", &LEAF),
            Field::bounded_string("s", 8),
        ],
    };

    /// The exact text `json.dumps(d, separators=(', ', ': '))` gives for this description
    /// (written out by hand from the rules, including the sorted, deduplicated references).
    #[test]
    fn hashed_json_layout() {
        assert_eq!(
            TOP.hashed_json(),
            "{\"type_description\": {\"type_name\": \"pkg/msg/Top\", \"fields\": [\
             {\"name\": \"mids\", \"type\": {\"type_id\": 145, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"pkg/msg/Mid\"}}, \
             {\"name\": \"leaf\", \"type\": {\"type_id\": 1, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"pkg/msg/Leaf\"}}, \
             {\"name\": \"s\", \"type\": {\"type_id\": 21, \"capacity\": 0, \"string_capacity\": 8, \"nested_type_name\": \"\"}}]}, \
             \"referenced_type_descriptions\": [\
             {\"type_name\": \"pkg/msg/Leaf\", \"fields\": [{\"name\": \"x\", \"type\": {\"type_id\": 6, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}, \
             {\"type_name\": \"pkg/msg/Mid\", \"fields\": [\
             {\"name\": \"leaf\", \"type\": {\"type_id\": 1, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"pkg/msg/Leaf\"}}, \
             {\"name\": \"a\", \"type\": {\"type_id\": 51, \"capacity\": 4, \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}]}"
        );
    }

    #[test]
    fn json_strings_are_escaped_as_python_does() {
        let mut s = String::new();
        json_str("a\"b\\c\u{e9}\n\u{1}", &mut s);
        assert_eq!(s, "\"a\\\"b\\\\c\\u00e9\\n\\u0001\"");
    }

    #[test]
    fn hash_format() {
        let h = LEAF.type_hash();
        assert!(h.starts_with("RIHS01_"));
        assert_eq!(h.len(), 7 + 64);
        assert!(h[7..].chars().all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase()));
        assert_ne!(h, MID.type_hash());
        assert_eq!(user_data(&LEAF), format!("typehash={h};").into_bytes());
    }
}
