//! NMEA framing: the IEC 61162-450 tag block, the sentence's frame and checksum, the talker.

use super::Reject;

/// What a line's tag block says.
#[derive(Debug, Default)]
pub(super) struct Tags<'a> {
    /// `c:` as written (an integer).
    pub(super) time: Option<i64>,
    /// `s:`.
    pub(super) source: Option<&'a str>,
}

pub(super) fn valid_talker(t: &[u8]) -> bool {
    t.len() == 2
        && t.iter()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit())
}

fn hex_byte(s: &[u8]) -> Option<u8> {
    let h = std::str::from_utf8(s).ok()?;
    if h.len() != 2 || !h.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u8::from_str_radix(h, 16).ok()
}

pub(super) fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |c, b| c ^ b)
}

/// Splits an optional leading tag block `\k:v,k:v*hh\` off the sentence.
pub(super) fn split_tag_block(text: &str) -> Result<(Tags<'_>, &str), Reject> {
    let Some(rest) = text.strip_prefix('\\') else {
        return Ok((Tags::default(), text));
    };
    let end = rest.find('\\').ok_or(Reject::TagBlock)?;
    let (block, sentence) = (&rest[..end], &rest[end + 1..]);
    let star = block.rfind('*').ok_or(Reject::TagBlock)?;
    let (params, hh) = (&block[..star], &block.as_bytes()[star + 1..]);
    if hex_byte(hh) != Some(xor(params.as_bytes())) {
        return Err(Reject::TagBlock);
    }
    let mut tags = Tags::default();
    for p in params.split(',') {
        let (k, v) = p.split_once(':').ok_or(Reject::TagBlock)?;
        match k {
            "c" => {
                if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(Reject::TagBlock);
                }
                tags.time = Some(v.parse().map_err(|_| Reject::TagBlock)?);
            }
            "s" => tags.source = Some(v),
            _ => {}
        }
    }
    Ok((tags, sentence))
}

/// `$` or `!`, an address, fields, `*`, two hex digits, nothing after. The address is five
/// letters or digits (talker and sentence type), or for a proprietary sentence (`$P`) `P`
/// and the maker's three-letter mnemonic with up to five more (`$PSXN`, `$PFEC`, `$PGRME`).
pub(super) fn check_framing(s: &str) -> Result<(), Reject> {
    let b = s.as_bytes();
    if b.len() < 9 || !(b[0] == b'$' || b[0] == b'!') {
        return Err(Reject::Framing);
    }
    let star = b.len() - 3;
    if b[star] != b'*' || hex_byte(&b[star + 1..]).is_none() {
        return Err(Reject::Framing);
    }
    let comma = b[1..star]
        .iter()
        .position(|c| *c == b',')
        .ok_or(Reject::Framing)?;
    let address = &b[1..1 + comma];
    let length_ok = match (b[0], address.first()) {
        (b'$', Some(b'P')) => (4..=9).contains(&address.len()),
        _ => address.len() == 5,
    };
    if !length_ok || !address.iter().all(|c| c.is_ascii_alphanumeric()) {
        return Err(Reject::Framing);
    }
    if b[1..star]
        .iter()
        .any(|c| matches!(c, b'$' | b'!' | b'*' | b'\\'))
    {
        return Err(Reject::Framing);
    }
    Ok(())
}

/// Whether the checksum of a framed sentence matches (for sentence types the crate does not
/// know, so that a corrupted known sentence is not counted as an unknown one).
pub(super) fn framing_checksum_ok(s: &str) -> bool {
    let b = s.as_bytes();
    let star = b.len() - 3;
    hex_byte(&b[star + 1..]) == Some(xor(&b[1..star]))
}
