//! Sentences out: what the simulated ship's instruments send (and the tests use), written
//! with the checksum and framing the decoder in the parent module checks.

use super::framing::xor;
use super::{HeadingSentence, KMH_MPS, KNOT_MPS, UDPBC};
use crate::wire::Input;

/// `$<talker><id>,<fields>*hh` (no line ending).
pub fn sentence(talker: &str, id: &str, fields: &str) -> String {
    let body = format!("{talker}{id},{fields}");
    format!("${body}*{:02X}", xor(body.as_bytes()))
}

/// A tag block `\<params>*hh\`.
pub fn tag_block(params: &str) -> String {
    format!("\\{params}*{:02X}\\", xor(params.as_bytes()))
}

/// `t` [s] as the tag block's `c:` in milliseconds (rounded), and the `t` a decoder with
/// `time-source = "tag-block-ms"` reads back from it.
pub fn tag_time_ms(t: f64) -> (i64, f64) {
    let ms = (t * 1000.0).round() as i64;
    (ms, ms as f64 / 1000.0)
}

/// The sentences of one tick of samples, as instruments send them: RSA (rudder), VHW
/// (speed), HTD (autopilot state and target, when the state is among `inputs`), the heading
/// last as `heading` says (HDT; THS in mode `A`; HDG with no deviation and no variation).
/// Three decimals of a degree and of a knot. `HTD`'s mode: `auto` -> S, anything else -> M.
pub fn tick_sentences(inputs: &[Input], heading_sentence: HeadingSentence) -> Vec<String> {
    let mut out = Vec::with_capacity(4);
    let mut state = None;
    let mut target = None;
    let mut heading = None;
    for i in inputs {
        match i {
            Input::Rudder(s) => out.push(sentence(
                "AG",
                "RSA",
                &format!("{:.3},A,,V", s.value.to_degrees()),
            )),
            Input::Speed(s) => {
                let kn = s.value / KNOT_MPS;
                out.push(sentence(
                    "VW",
                    "VHW",
                    &format!(",T,,M,{kn:.3},N,{:.3},K", s.value / KMH_MPS),
                ));
            }
            Input::AutopilotState(s) => state = Some(s.value.clone()),
            Input::TargetHeading(s) => target = Some(s.value),
            Input::Heading(s) => heading = Some(s.value),
            Input::DesignDisplacement(_) => {}
        }
    }
    if let Some(state) = state {
        let mode = if state == "auto" { "S" } else { "M" };
        let target = target.map_or(String::new(), |v| format!("{:.3}", v.to_degrees()));
        out.push(sentence(
            "AG",
            "HTD",
            &format!("V,,,{mode},N,,,,,{target},,,T,A,A,A,"),
        ));
    }
    if let Some(h) = heading {
        let d = h.to_degrees();
        out.push(match heading_sentence {
            HeadingSentence::Hdt => sentence("HE", "HDT", &format!("{d:.3},T")),
            HeadingSentence::Ths => sentence("HE", "THS", &format!("{d:.3},A")),
            HeadingSentence::Hdg => sentence("HC", "HDG", &format!("{d:.3},0.0,E,0.0,E")),
        });
    }
    out
}

/// An IEC 61162-450 datagram: `UdPbC\0`, then each sentence behind a tag block
/// `s:<source>,c:<ms>`, each line ended by CR LF.
pub fn datagram(source: &str, time_ms: i64, sentences: &[String]) -> Vec<u8> {
    let mut d = UDPBC.to_vec();
    let tag = tag_block(&format!("s:{source},c:{time_ms}"));
    for s in sentences {
        d.extend_from_slice(tag.as_bytes());
        d.extend_from_slice(s.as_bytes());
        d.extend_from_slice(b"\r\n");
    }
    d
}
