//! Arrow IPC metadata checked before the arrow-ipc readers use it.
//!
//! The readers trust the lengths and offsets in an IPC file's footer and message headers:
//! a block or buffer reaching past the data makes them panic (slicing) or allocate what the
//! header claims. This pre-pass reads only the metadata (footer, message headers; seeking
//! over bodies) and checks that every block lies inside the file, every message's body
//! inside the data, and every buffer inside its message's body — so such files fail with an
//! error naming the block or message instead.

use arrow_ipc::MessageHeader;
use std::io::{Read, Seek, SeekFrom};

/// The most bytes one IPC message header (flatbuffer metadata) may take.
pub const MAX_IPC_METADATA: u64 = 16 << 20;

type Check = std::result::Result<(), String>;

/// The 0xFFFFFFFF that precedes a message's metadata length (since Arrow 0.15).
const CONTINUATION_MARKER: [u8; 4] = [0xff; 4];

fn read_exact_at<R: Read + Seek>(r: &mut R, at: u64, buf: &mut [u8]) -> std::io::Result<()> {
    r.seek(SeekFrom::Start(at))?;
    r.read_exact(buf)
}

/// Check the message at `at` (continuation marker optional, then the metadata length and
/// the metadata): its buffers lie inside its body, of the declared length or `body_len`
/// bytes if shorter; returns the metadata's size with its prefix and the declared body
/// length (`None` at an end-of-stream marker).
fn check_message<R: Read + Seek>(r: &mut R, at: u64, body_len: u64, what: &str) -> Result<Option<(u64, u64)>, String> {
    let io = |e: std::io::Error| format!("{what} at byte {at}: {e}");
    let mut word = [0u8; 4];
    read_exact_at(r, at, &mut word).map_err(io)?;
    let mut prefix = 4u64;
    if word == CONTINUATION_MARKER {
        r.read_exact(&mut word).map_err(io)?;
        prefix = 8;
    }
    let meta_len = i32::from_le_bytes(word);
    if meta_len == 0 {
        return Ok(None); // end of stream
    }
    let meta_len = u64::try_from(meta_len).map_err(|_| format!("{what} at byte {at}: metadata length {meta_len}"))?;
    if meta_len > MAX_IPC_METADATA {
        return Err(format!("{what} at byte {at}: {meta_len} bytes of metadata (at most {MAX_IPC_METADATA})"));
    }
    let mut meta = vec![0u8; meta_len as usize];
    r.read_exact(&mut meta).map_err(|e| format!("{what} at byte {at}: metadata of {meta_len} bytes: {e}"))?;
    let msg = arrow_ipc::root_as_message(&meta).map_err(|e| format!("{what} at byte {at}: malformed metadata: {e}"))?;
    let declared = msg.bodyLength();
    let declared = u64::try_from(declared).map_err(|_| format!("{what} at byte {at}: a body of {declared} bytes"))?;
    // a file's reader takes the body from the footer's block (`body_len`), a stream's from
    // the message: the buffers must lie in the one that is read
    let body = declared.min(body_len);
    let buffers = match msg.header_type() {
        MessageHeader::RecordBatch => msg.header_as_record_batch().and_then(|b| b.buffers()),
        MessageHeader::DictionaryBatch => {
            msg.header_as_dictionary_batch().and_then(|d| d.data()).and_then(|b| b.buffers())
        }
        _ => None,
    };
    for (i, b) in buffers.iter().flat_map(|v| v.iter()).enumerate() {
        let (o, l) = (b.offset(), b.length());
        let end = u64::try_from(o).ok().zip(u64::try_from(l).ok()).and_then(|(o, l)| o.checked_add(l));
        if end.is_none_or(|e| e > body) {
            return Err(format!(
                "{what} at byte {at}: buffer {i} (offset {o}, length {l}) lies outside its body of {body} bytes"
            ));
        }
    }
    Ok(Some((prefix + meta_len, declared)))
}

/// Check an IPC *file* (`ARROW1` magic) of `len` bytes: its footer's blocks and their messages.
pub(crate) fn check_file<R: Read + Seek>(r: &mut R, len: u64) -> Check {
    if len < 6 + 2 + 4 + 6 {
        return Err(format!("{len} bytes: too short for an Arrow IPC file"));
    }
    let mut tail = [0u8; 10];
    read_exact_at(r, len - 10, &mut tail).map_err(|e| e.to_string())?;
    if &tail[4..] != b"ARROW1" {
        return Err("no ARROW1 magic at the end: not an Arrow IPC file (truncated?)".into());
    }
    let footer_len = i32::from_le_bytes(tail[..4].try_into().unwrap());
    let footer_len =
        u64::try_from(footer_len).ok().filter(|&f| f <= len - 18).ok_or(format!("footer length {footer_len}"))?;
    let data_end = len - 10 - footer_len;
    let mut footer = vec![0u8; footer_len as usize];
    read_exact_at(r, data_end, &mut footer).map_err(|e| e.to_string())?;
    let footer = arrow_ipc::root_as_footer(&footer).map_err(|e| format!("malformed footer: {e}"))?;
    let kinds = [("dictionary", footer.dictionaries()), ("record batch", footer.recordBatches())];
    for (kind, blocks) in kinds {
        for (i, b) in blocks.iter().flat_map(|v| v.iter()).enumerate() {
            let what = format!("{kind} {i}");
            let (o, m, l) = (b.offset(), b.metaDataLength(), b.bodyLength());
            let (Ok(uo), Ok(um), Ok(ul)) = (u64::try_from(o), u64::try_from(m), u64::try_from(l)) else {
                return Err(format!("{what}: block (offset {o}, metadata {m}, body {l} bytes) is negative"));
            };
            if uo.checked_add(um).and_then(|x| x.checked_add(ul)).is_none_or(|end| end > len) {
                return Err(format!(
                    "{what}: block (offset {o}, metadata {m}, body {l} bytes) ends past the end of the file ({len} bytes)"
                ));
            }
            match check_message(r, uo, ul, &what)? {
                Some((meta, _)) if meta <= um => {}
                _ => return Err(format!("{what}: its message does not fit the block's {m} metadata bytes")),
            }
        }
    }
    Ok(())
}

/// Check an IPC *stream* of `len` bytes from the reader's start: every message's metadata
/// and body lie inside it.
pub(crate) fn check_stream<R: Read + Seek>(r: &mut R, len: u64) -> Check {
    let mut at = 0u64;
    let mut n = 0u64;
    while at < len {
        let what = format!("message {n}");
        let Some((meta, body)) = check_message(r, at, len.saturating_sub(at), &what)? else { return Ok(()) };
        match (at + meta).checked_add(body).filter(|&e| e <= len) {
            Some(end) => at = end,
            None => {
                return Err(format!("{what} at byte {at}: a body of {body} bytes, but the stream ends at byte {len}"))
            }
        }
        n += 1;
    }
    Ok(())
}
