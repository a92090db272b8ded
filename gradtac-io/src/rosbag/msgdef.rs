//! ROS message definitions (`.msg` text, as a ROS 1 bag embeds it in each connection and an
//! MCAP file in each `ros2msg` schema), parsed into a [`Schema`] that drives the generic
//! [decoder](super::decode).
//!
//! The text is the root type's fields, then for every type it uses a separator line of `=`
//! and `MSG: pkg/Type` followed by that type's fields. A field line is `TYPE NAME` (ROS 2
//! may add a default value after the name), `#` starts a comment, and `TYPE NAME=VALUE` is a
//! constant (not on the wire; skipped). `TYPE` is a primitive or a message type, optionally
//! followed by `[]` (a sequence with a `u32` length on the wire), `[N]` (a fixed array) or
//! `[<=N]` (a bounded sequence, ROS 2). Nested types are named `pkg/Type` (also
//! `pkg/msg/Type`), or by the bare name within the same package; `Header` is
//! `std_msgs/Header`.
//!
//! | primitive | ROS 1 | ROS 2 |
//! |---|---|---|
//! | `bool`, `int8` … `uint64`, `float32`, `float64`, `string` | yes | yes (`string<=N` too) |
//! | `byte` | `int8` | `uint8` (octet) |
//! | `char` | `uint8` | `uint8` |
//! | `time`, `duration` | `u32`/`i32` seconds + nanoseconds | (ROS 2 uses `builtin_interfaces/Time`, a message) |
//!
//! `wstring` is not supported. Bounds: at most [`MAX_TYPES`] types, [`MAX_DEPTH`] levels of
//! nesting (a definition that contains itself is an error) and fixed arrays of at most
//! [`MAX_FIXED_LEN`] elements.

use std::fmt;

/// Most message types one definition may hold.
pub const MAX_TYPES: usize = 1024;
/// Deepest nesting of message types.
pub const MAX_DEPTH: usize = 32;
/// Longest fixed-size array (`T[N]`).
pub const MAX_FIXED_LEN: u32 = 1 << 20;

/// Which ROS generation's definition rules apply (they differ in `byte`, `time`, `duration`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    /// ROS 1 (bag files).
    Ros1,
    /// ROS 2 (MCAP `ros2msg` schemas).
    Ros2,
}

/// A primitive field type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    /// `bool` (one byte).
    Bool,
    /// `int8` (ROS 1 `byte`).
    I8,
    /// `uint8` (`char`, ROS 2 `byte`).
    U8,
    /// `int16`.
    I16,
    /// `uint16`.
    U16,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `int64`.
    I64,
    /// `uint64`.
    U64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
    /// `string`.
    String,
    /// ROS 1 `time`: `u32` seconds, `u32` nanoseconds.
    Time,
    /// ROS 1 `duration`: `i32` seconds, `i32` nanoseconds.
    Duration,
}

impl Primitive {
    fn parse(s: &str, d: Dialect) -> Option<Self> {
        Some(match s {
            "bool" => Primitive::Bool,
            "int8" => Primitive::I8,
            "uint8" | "char" => Primitive::U8,
            "byte" if d == Dialect::Ros1 => Primitive::I8,
            "byte" => Primitive::U8,
            "int16" => Primitive::I16,
            "uint16" => Primitive::U16,
            "int32" => Primitive::I32,
            "uint32" => Primitive::U32,
            "int64" => Primitive::I64,
            "uint64" => Primitive::U64,
            "float32" => Primitive::F32,
            "float64" => Primitive::F64,
            "string" => Primitive::String,
            "time" if d == Dialect::Ros1 => Primitive::Time,
            "duration" if d == Dialect::Ros1 => Primitive::Duration,
            _ => return None,
        })
    }

    /// Bytes on the wire (strings: their length prefix; ROS 1 time/duration: 8).
    pub fn size(self) -> usize {
        match self {
            Primitive::Bool | Primitive::I8 | Primitive::U8 => 1,
            Primitive::I16 | Primitive::U16 => 2,
            Primitive::I32 | Primitive::U32 | Primitive::F32 | Primitive::String => 4,
            Primitive::I64 | Primitive::U64 | Primitive::F64 | Primitive::Time | Primitive::Duration => 8,
        }
    }

    /// True for the integer types.
    pub fn is_integer(self) -> bool {
        matches!(
            self,
            Primitive::I8
                | Primitive::U8
                | Primitive::I16
                | Primitive::U16
                | Primitive::I32
                | Primitive::U32
                | Primitive::I64
                | Primitive::U64
        )
    }
}

/// A field's element type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// A primitive.
    Primitive(Primitive),
    /// A message type: index into [`Schema::types`].
    Message(usize),
}

/// Single value, fixed array or sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    /// One value.
    One,
    /// `T[N]`: exactly N values, no length on the wire.
    Fixed(u32),
    /// `T[]` or `T[<=N]`: a `u32` length, then the values.
    Sequence,
}

/// One field of a message type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// Its element type.
    pub ty: FieldType,
    /// One, fixed or sequence.
    pub arity: Arity,
}

/// A message type and its fields, in wire order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MsgType {
    /// `pkg/Type`.
    pub name: String,
    /// The fields.
    pub fields: Vec<Field>,
}

impl MsgType {
    /// The index of the field called `name`.
    pub fn field(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }
}

/// A parsed, resolved message definition; `types[root]` is the message's own type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Schema {
    /// Every type of the definition.
    pub types: Vec<MsgType>,
    /// The root type's index.
    pub root: usize,
    /// Which rules it was parsed with.
    pub dialect: Dialect,
    /// Minimal wire size of each type.
    min_sizes: Vec<usize>,
}

/// A definition that cannot be parsed or resolved: the 1-based line of the text and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DefinitionError {
    /// 1-based line in the definition text (0: not about one line).
    pub line: usize,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for DefinitionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "message definition line {}: {}", self.line, self.reason)
        } else {
            write!(f, "message definition: {}", self.reason)
        }
    }
}

/// `pkg/msg/Type` → `pkg/Type`.
fn normalise(name: &str) -> String {
    match name.split('/').collect::<Vec<_>>().as_slice() {
        [pkg, "msg", t] => format!("{pkg}/{t}"),
        _ => name.to_string(),
    }
}

fn package(name: &str) -> &str {
    name.split('/').next().unwrap_or("")
}

/// A field before type resolution.
struct RawField {
    line: usize,
    name: String,
    ty: String,
    arity: Arity,
}

impl Schema {
    /// Parse the definition `text` of type `root_type` (`pkg/Type` or `pkg/msg/Type`).
    pub fn parse(root_type: &str, text: &str, dialect: Dialect) -> Result<Schema, DefinitionError> {
        let err = |line: usize, reason: String| DefinitionError { line, reason };
        let mut sections: Vec<(String, Vec<RawField>)> = vec![(normalise(root_type), Vec::new())];
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            let l = raw.trim();
            if let Some(name) = l.strip_prefix("MSG:") {
                if sections.len() >= MAX_TYPES {
                    return Err(err(line, format!("more than {MAX_TYPES} message types")));
                }
                let name = name.trim();
                if name.is_empty() {
                    return Err(err(line, "`MSG:` names no type".into()));
                }
                sections.push((normalise(name), Vec::new()));
                continue;
            }
            if l.is_empty() || l.starts_with('#') || (l.len() >= 3 && l.bytes().all(|c| c == b'=')) {
                continue;
            }
            let (ty_tok, rest) =
                l.split_once(char::is_whitespace).ok_or_else(|| err(line, format!("{l:?} is not `TYPE NAME`")))?;
            let rest = rest.trim_start();
            let name_end = rest.find(|c: char| c.is_whitespace() || c == '=' || c == '#').unwrap_or(rest.len());
            let name = &rest[..name_end];
            if rest[name_end..].trim_start().starts_with('=') {
                continue; // a constant
            }
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(err(line, format!("bad field name in {l:?}")));
            }
            let (base, arity) = match ty_tok.find('[') {
                None => (ty_tok, Arity::One),
                Some(i) => {
                    let inner = ty_tok[i + 1..]
                        .strip_suffix(']')
                        .ok_or_else(|| err(line, format!("bad array type {ty_tok:?}")))?;
                    let arity = if inner.is_empty() || inner.starts_with("<=") {
                        Arity::Sequence
                    } else {
                        let n: u32 = inner.parse().map_err(|_| err(line, format!("bad array length in {ty_tok:?}")))?;
                        if n > MAX_FIXED_LEN {
                            return Err(err(line, format!("array length {n} over the limit {MAX_FIXED_LEN}")));
                        }
                        Arity::Fixed(n)
                    };
                    (&ty_tok[..i], arity)
                }
            };
            let base = base.split("<=").next().unwrap_or(base);
            let fields = &mut sections.last_mut().expect("never empty").1;
            fields.push(RawField { line, name: name.to_string(), ty: base.to_string(), arity });
        }
        // resolve
        let names: Vec<String> = sections.iter().map(|(n, _)| n.clone()).collect();
        let mut types = Vec::with_capacity(sections.len());
        for (tname, raw) in &sections {
            let mut fields = Vec::with_capacity(raw.len());
            for f in raw {
                let ty = if f.ty == "wstring" {
                    return Err(err(f.line, "wstring fields are not supported".into()));
                } else if let Some(p) = Primitive::parse(&f.ty, dialect) {
                    FieldType::Primitive(p)
                } else {
                    FieldType::Message(resolve(&names, tname, &f.ty).ok_or_else(|| {
                        err(f.line, format!("type {:?} of field {:?} is not defined in the text", f.ty, f.name))
                    })?)
                };
                fields.push(Field { name: f.name.clone(), ty, arity: f.arity });
            }
            types.push(MsgType { name: tname.clone(), fields });
        }
        let mut schema = Schema { types, root: 0, dialect, min_sizes: Vec::new() };
        schema.check()?;
        Ok(schema)
    }

    /// Check nesting (no cycles, depth ≤ [`MAX_DEPTH`]) and compute each type's minimal wire
    /// size, visiting each type once.
    fn check(&mut self) -> Result<(), DefinitionError> {
        let n = self.types.len();
        let mut state = vec![0u8; n];
        let mut sizes = vec![0usize; n];
        self.visit(self.root, 0, &mut state, &mut sizes)?;
        for t in 0..n {
            if state[t] == 0 {
                self.visit(t, 0, &mut state, &mut sizes)?;
            }
        }
        self.min_sizes = sizes;
        Ok(())
    }

    fn visit(&self, t: usize, depth: usize, state: &mut [u8], sizes: &mut [usize]) -> Result<usize, DefinitionError> {
        match state[t] {
            2 => return Ok(sizes[t]),
            1 => {
                return Err(DefinitionError { line: 0, reason: format!("type {} contains itself", self.types[t].name) })
            }
            _ => {}
        }
        if depth > MAX_DEPTH {
            return Err(DefinitionError { line: 0, reason: format!("types nest deeper than {MAX_DEPTH} levels") });
        }
        state[t] = 1;
        let mut total = 0usize;
        for f in &self.types[t].fields {
            let one = match f.ty {
                FieldType::Primitive(p) => p.size(),
                FieldType::Message(u) => self.visit(u, depth + 1, state, sizes)?,
            };
            let size = match f.arity {
                Arity::One => one,
                Arity::Fixed(k) => (k as usize).saturating_mul(one),
                Arity::Sequence => 4,
            };
            total = total.saturating_add(size);
        }
        state[t] = 2;
        sizes[t] = total;
        Ok(total)
    }

    /// The root type.
    pub fn root_type(&self) -> &MsgType {
        &self.types[self.root]
    }

    /// Smallest wire size of one value of `ty` without alignment padding (bounds sequence
    /// lengths against the bytes left).
    pub fn min_size(&self, ty: FieldType) -> usize {
        match ty {
            FieldType::Primitive(p) => p.size(),
            FieldType::Message(t) => self.min_sizes[t],
        }
    }
}

/// Find a type named `ty` as used in a field of type `from`.
fn resolve(names: &[String], from: &str, ty: &str) -> Option<usize> {
    let ty = normalise(ty);
    let candidates: Vec<String> = if ty.contains('/') {
        vec![ty.clone()]
    } else if ty == "Header" {
        vec!["std_msgs/Header".into(), format!("{}/Header", package(from))]
    } else {
        vec![format!("{}/{ty}", package(from))]
    };
    for c in &candidates {
        if let Some(i) = names.iter().position(|n| n == c) {
            return Some(i);
        }
    }
    // a bare name used across packages: accept a unique match by type name
    let short = ty.rsplit('/').next().unwrap_or(&ty);
    let mut hits = names.iter().enumerate().filter(|(_, n)| n.rsplit('/').next() == Some(short));
    match (hits.next(), hits.next()) {
        (Some((i, _)), None) => Some(i),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const BIOTAC_ALL: &str = "Header header\nBiotac[5] tactiles\n\
================================================================================\n\
MSG: std_msgs/Header\n# comment\nuint32 seq\ntime stamp\nstring frame_id\n\
================================================================================\n\
MSG: sr_robot_msgs/Biotac\nint16 pac0\nint16 pac1\nint16 pdc\n\nint16 tac\nint16 tdc\n\nint16[] electrodes\n";

    #[test]
    fn parses_the_shadow_definition() {
        let s = Schema::parse("sr_robot_msgs/BiotacAll", BIOTAC_ALL, Dialect::Ros1).unwrap();
        let root = s.root_type();
        assert_eq!(root.name, "sr_robot_msgs/BiotacAll");
        assert_eq!(root.fields[1].arity, Arity::Fixed(5));
        let FieldType::Message(b) = root.fields[1].ty else { panic!() };
        assert_eq!(s.types[b].name, "sr_robot_msgs/Biotac");
        let e = &s.types[b].fields[5];
        assert_eq!(
            (e.name.as_str(), e.ty, e.arity),
            ("electrodes", FieldType::Primitive(Primitive::I16), Arity::Sequence)
        );
        let FieldType::Message(h) = root.fields[0].ty else { panic!() };
        assert_eq!(s.types[h].fields[1].ty, FieldType::Primitive(Primitive::Time));
        // header 4+8+4, five biotacs of 5·2 + 4
        assert_eq!(s.min_size(FieldType::Message(0)), 16 + 5 * 14);
    }

    #[test]
    fn constants_defaults_bounds_and_ros2_names() {
        let text = "int32 FOO=3\nstring BAR = a=b # x\nint32 x 5\nstring<=8 s\nint16[<=4] v\nbyte b\nbuiltin_interfaces/Time t\n\
=====\nMSG: builtin_interfaces/msg/Time\nint32 sec\nuint32 nanosec\n";
        let s = Schema::parse("p/msg/T", text, Dialect::Ros2).unwrap();
        let names: Vec<&str> = s.root_type().fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["x", "s", "v", "b", "t"]);
        assert_eq!(s.root_type().fields[2].arity, Arity::Sequence);
        assert_eq!(s.root_type().fields[3].ty, FieldType::Primitive(Primitive::U8));
        assert_eq!(s.types[1].name, "builtin_interfaces/Time");
    }

    #[test]
    fn errors_name_the_line() {
        let e = Schema::parse("p/T", "int32 a\nFoo b\n", Dialect::Ros1).unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.to_string().contains("\"Foo\""), "{e}");
        let e = Schema::parse("p/T", "int32[x] a\n", Dialect::Ros1).unwrap_err();
        assert!(e.reason.contains("array length"));
        let e = Schema::parse("p/T", "T a\n", Dialect::Ros1).unwrap_err();
        assert!(e.reason.contains("contains itself"), "{e}");
        assert!(Schema::parse("p/T", "int32[99999999] a\n", Dialect::Ros1).is_err());
        assert!(Schema::parse("p/T", "time t\n", Dialect::Ros2).is_err());
    }
}
