//! A generic message decoder driven by a [`Schema`]: ROS 1 serialisation (bags) and CDR
//! (ROS 2, MCAP).
//!
//! - **ROS 1**: little-endian, packed (no padding); `string` and sequences carry a `u32`
//!   length (strings without a terminating NUL); `time` = `u32` sec + `u32` nsec.
//! - **CDR** (XCDR1, what ROS 2's default middleware writes): a 4-byte encapsulation header
//!   (`00 01` little-endian, `00 00` big-endian; the next two bytes are options), then every
//!   primitive aligned to its size (1, 2, 4, 8) counted from the end of that header; `string`
//!   is a `u32` length *including* a terminating NUL, then the bytes; sequences a `u32` count.
//!
//! Every length is checked against the bytes left before anything is allocated (a sequence
//! of `n` elements needs at least `n · min_size` bytes), so malformed input is an error,
//! never a panic or an allocation larger than the message.

use super::msgdef::{Arity, FieldType, Primitive, Schema};

/// A decoded value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `bool`.
    Bool(bool),
    /// Any integer type but `uint64`.
    Int(i64),
    /// `uint64`.
    UInt(u64),
    /// `float32` / `float64`.
    Float(f64),
    /// `string` (invalid UTF-8 replaced).
    Str(String),
    /// ROS 1 `time` / `duration`: seconds and nanoseconds.
    Time {
        /// Seconds.
        sec: i64,
        /// Nanoseconds.
        nsec: i64,
    },
    /// An array or sequence of integers (all types but `uint64`).
    Ints(Vec<i64>),
    /// An array or sequence of anything else.
    List(Vec<Value>),
    /// A message: its fields' values in definition order.
    Struct(Vec<Value>),
}

/// How messages are serialised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// ROS 1.
    Ros1,
    /// CDR with its encapsulation header.
    Cdr,
}

/// Why a message did not decode: the byte offset in the message and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DecodeError {
    /// Byte offset in the message.
    pub offset: usize,
    /// What is wrong.
    pub reason: String,
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "at byte {} of the message: {}", self.offset, self.reason)
    }
}

struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    little: bool,
    /// CDR: alignment origin; `None` for ROS 1 (packed).
    origin: Option<usize>,
}

type R<T> = Result<T, DecodeError>;

impl<'a> Cursor<'a> {
    fn fail<T>(&self, reason: impl Into<String>) -> R<T> {
        Err(DecodeError { offset: self.pos, reason: reason.into() })
    }

    fn align(&mut self, n: usize) -> R<()> {
        if let Some(o) = self.origin {
            let rem = (self.pos - o) % n;
            if rem != 0 {
                let p = self.pos + (n - rem);
                if p > self.b.len() {
                    return self.fail("the message ends in alignment padding");
                }
                self.pos = p;
            }
        }
        Ok(())
    }

    fn take(&mut self, n: usize) -> R<&'a [u8]> {
        self.align(n.clamp(1, 8))?;
        self.raw(n)
    }

    fn raw(&mut self, n: usize) -> R<&'a [u8]> {
        match self.b.get(self.pos..self.pos.saturating_add(n)) {
            Some(s) if s.len() == n => {
                self.pos += n;
                Ok(s)
            }
            _ => self.fail(format!("the message ends ({} bytes) where {n} more were expected", self.b.len())),
        }
    }

    fn uint(&mut self, n: usize) -> R<u64> {
        let s = self.take(n)?;
        let mut v = 0u64;
        if self.little {
            for (i, &c) in s.iter().enumerate() {
                v |= u64::from(c) << (8 * i);
            }
        } else {
            for &c in s {
                v = v << 8 | u64::from(c);
            }
        }
        Ok(v)
    }

    fn u32(&mut self) -> R<u32> {
        self.uint(4).map(|v| v as u32)
    }

    fn left(&self) -> usize {
        self.b.len() - self.pos
    }

    fn int(&mut self, p: Primitive) -> R<i64> {
        Ok(match p {
            Primitive::I8 => self.uint(1)? as u8 as i8 as i64,
            Primitive::U8 => self.uint(1)? as i64,
            Primitive::I16 => self.uint(2)? as u16 as i16 as i64,
            Primitive::U16 => self.uint(2)? as i64,
            Primitive::I32 => self.uint(4)? as u32 as i32 as i64,
            Primitive::U32 => self.uint(4)? as i64,
            Primitive::I64 => self.uint(8)? as i64,
            _ => return self.fail("internal: not an integer"),
        })
    }

    fn string(&mut self) -> R<String> {
        let n = self.u32()? as usize;
        if n > self.left() {
            return self.fail(format!("a string of {n} bytes, but {} are left", self.left()));
        }
        let mut s = self.raw(n)?;
        if self.origin.is_some() {
            // CDR: the length counts a terminating NUL
            s = s.strip_suffix(&[0]).unwrap_or(s);
        }
        Ok(String::from_utf8_lossy(s).into_owned())
    }

    fn primitive(&mut self, p: Primitive) -> R<Value> {
        Ok(match p {
            Primitive::Bool => Value::Bool(self.uint(1)? != 0),
            Primitive::U64 => Value::UInt(self.uint(8)?),
            Primitive::F32 => Value::Float(f64::from(f32::from_bits(self.uint(4)? as u32))),
            Primitive::F64 => Value::Float(f64::from_bits(self.uint(8)?)),
            Primitive::String => Value::Str(self.string()?),
            Primitive::Time => {
                let sec = self.uint(4)? as u32;
                Value::Time { sec: i64::from(sec), nsec: i64::from(self.uint(4)? as u32) }
            }
            Primitive::Duration => {
                let sec = self.uint(4)? as u32 as i32;
                Value::Time { sec: i64::from(sec), nsec: i64::from(self.uint(4)? as u32 as i32) }
            }
            p => Value::Int(self.int(p)?),
        })
    }
}

/// Decode one message of the schema's root type.
pub fn decode(schema: &Schema, wire: Wire, bytes: &[u8]) -> Result<Value, DecodeError> {
    let mut c = Cursor { b: bytes, pos: 0, little: true, origin: None };
    if wire == Wire::Cdr {
        let h = c.raw(4)?;
        c.little = match h[..2] {
            [0, 1] | [0, 3] => true,
            [0, 0] | [0, 2] => false,
            _ => {
                return Err(DecodeError {
                    offset: 0,
                    reason: format!("unknown CDR encapsulation {:02x}{:02x}", h[0], h[1]),
                })
            }
        };
        c.origin = Some(4);
    }
    message(schema, schema.root, &mut c)
}

fn message(s: &Schema, t: usize, c: &mut Cursor<'_>) -> R<Value> {
    let ty = &s.types[t];
    let mut out = Vec::with_capacity(ty.fields.len());
    for f in &ty.fields {
        let v = match f.arity {
            Arity::One => one(s, f.ty, c)?,
            Arity::Fixed(n) => many(s, f.ty, n as usize, c)?,
            Arity::Sequence => {
                let n = c.u32()? as usize;
                many(s, f.ty, n, c)?
            }
        };
        out.push(v);
    }
    Ok(Value::Struct(out))
}

fn one(s: &Schema, ty: FieldType, c: &mut Cursor<'_>) -> R<Value> {
    match ty {
        FieldType::Primitive(p) => c.primitive(p),
        FieldType::Message(t) => message(s, t, c),
    }
}

fn many(s: &Schema, ty: FieldType, n: usize, c: &mut Cursor<'_>) -> R<Value> {
    let min = s.min_size(ty);
    if n.saturating_mul(min.max(1)) > c.left().saturating_add(if min == 0 { 1 << 16 } else { 0 }) {
        return c.fail(format!("{n} elements of at least {min} bytes, but {} bytes are left", c.left()));
    }
    match ty {
        FieldType::Primitive(p) if p.is_integer() && p != Primitive::U64 => {
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(c.int(p)?);
            }
            Ok(Value::Ints(v))
        }
        _ => {
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(one(s, ty, c)?);
            }
            Ok(Value::List(v))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rosbag::msgdef::Dialect;

    #[test]
    fn ros1_packed() {
        let s = Schema::parse("p/T", "uint8 a\nint16[] b\nstring c\ntime t\nfloat32[2] f\n", Dialect::Ros1).unwrap();
        let mut m = vec![7u8];
        m.extend(2u32.to_le_bytes());
        m.extend((-2i16).to_le_bytes());
        m.extend(300i16.to_le_bytes());
        m.extend(2u32.to_le_bytes());
        m.extend(b"hi");
        m.extend(5u32.to_le_bytes());
        m.extend(6u32.to_le_bytes());
        m.extend(1.5f32.to_le_bytes());
        m.extend((-0.25f32).to_le_bytes());
        let v = decode(&s, Wire::Ros1, &m).unwrap();
        assert_eq!(
            v,
            Value::Struct(vec![
                Value::Int(7),
                Value::Ints(vec![-2, 300]),
                Value::Str("hi".into()),
                Value::Time { sec: 5, nsec: 6 },
                Value::List(vec![Value::Float(1.5), Value::Float(-0.25)]),
            ])
        );
        // every truncation is an error, never a panic
        for k in 0..m.len() {
            assert!(decode(&s, Wire::Ros1, &m[..k]).is_err());
        }
    }

    #[test]
    fn cdr_aligned_both_endians() {
        let s = Schema::parse("p/T", "uint8 a\nint16[] b\nstring c\nfloat64 d\n", Dialect::Ros2).unwrap();
        // little endian: 00 01 00 00 | a=7 pad | len(2) | -2 300 | len 3 "hi\0" | pad to 8 | d
        let mut m = vec![0, 1, 0, 0, 7, 0, 0, 0];
        m.extend(2u32.to_le_bytes());
        m.extend((-2i16).to_le_bytes());
        m.extend(300i16.to_le_bytes());
        m.extend(3u32.to_le_bytes());
        m.extend(b"hi\0");
        m.extend([0; 5]);
        m.extend(2.5f64.to_le_bytes());
        let want =
            Value::Struct(vec![Value::Int(7), Value::Ints(vec![-2, 300]), Value::Str("hi".into()), Value::Float(2.5)]);
        assert_eq!(decode(&s, Wire::Cdr, &m).unwrap(), want);
        let mut b = vec![0, 0, 0, 0, 7, 0, 0, 0];
        b.extend(2u32.to_be_bytes());
        b.extend((-2i16).to_be_bytes());
        b.extend(300i16.to_be_bytes());
        b.extend(3u32.to_be_bytes());
        b.extend(b"hi\0");
        b.extend([0; 5]);
        b.extend(2.5f64.to_be_bytes());
        assert_eq!(decode(&s, Wire::Cdr, &b).unwrap(), want);
    }

    #[test]
    fn huge_lengths_are_refused_before_allocating() {
        let s = Schema::parse("p/T", "int16[] b\n", Dialect::Ros1).unwrap();
        let e = decode(&s, Wire::Ros1, &u32::MAX.to_le_bytes()).unwrap_err();
        assert!(e.reason.contains("bytes are left"), "{e}");
        let s = Schema::parse("p/T", "E[] b\n===\nMSG: p/E\n", Dialect::Ros1).unwrap();
        assert!(decode(&s, Wire::Ros1, &u32::MAX.to_le_bytes()).is_err());
    }
}
