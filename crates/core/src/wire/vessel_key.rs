//! The vessel keys' grammar, taken apart in one place: `vessels/<vessel>/<rest>` (see
//! docs/contract.md) and the ownership tokens' `fdi/<what>/<id>`.

/// The part every vessel key starts with.
pub const PREFIX: &str = "vessels/";

/// A key `vessels/<vessel>/<rest>`, taken apart (borrowing the key).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VesselKey<'a> {
    /// The vessel: not empty, without `/` (its characters are not checked: see
    /// `config::check_vessel_name`).
    pub vessel: &'a str,
    /// What follows `vessels/<vessel>/` (may be empty).
    pub rest: &'a str,
}

/// `key` as `vessels/<vessel>/<rest>`; `None` when it does not start with `vessels/`, the
/// vessel is empty or no `/` follows it.
pub fn split(key: &str) -> Option<VesselKey<'_>> {
    let (vessel, rest) = key.strip_prefix(PREFIX)?.split_once('/')?;
    (!vessel.is_empty()).then_some(VesselKey { vessel, rest })
}

impl<'a> VesselKey<'a> {
    /// A liveliness token's `fdi/<what>/<id>` as `(what, id)`, `id` being everything after
    /// `fdi/<what>/` (possibly empty, possibly with `/`: the caller checks what it needs).
    pub fn fdi_token(&self) -> Option<(&'a str, &'a str)> {
        self.rest.strip_prefix("fdi/")?.split_once('/')
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_a_vessel_key() {
        let k = split("vessels/self/navigation/headingTrue").unwrap();
        assert_eq!(k.vessel, "self");
        assert_eq!(k.rest, "navigation/headingTrue");
        let k = split("vessels/366123456/fdi/state").unwrap();
        assert_eq!((k.vessel, k.rest), ("366123456", "fdi/state"));
        // A trailing slash: an empty rest.
        let k = split("vessels/a/").unwrap();
        assert_eq!((k.vessel, k.rest), ("a", ""));
        // Wildcards are only characters here.
        let k = split("vessels/*/fdi/trigger").unwrap();
        assert_eq!((k.vessel, k.rest), ("*", "fdi/trigger"));
    }

    #[test]
    fn refuses_what_is_not_a_vessel_key() {
        for key in [
            "",
            "vessels",
            "vessels/",
            "vessels/a",
            "vessels//fdi/state",
            "vessel/a/fdi/state",
            "other/a/fdi/alive",
            "/vessels/a/fdi/state",
            "Vessels/a/fdi/state",
        ] {
            assert_eq!(split(key), None, "{key:?}");
        }
    }

    #[test]
    fn takes_an_ownership_token_apart() {
        let token = |key| split(key).unwrap().fdi_token();
        assert_eq!(token("vessels/v/fdi/holder/d-1"), Some(("holder", "d-1")));
        assert_eq!(
            token("vessels/v/fdi/candidate/d/2"),
            Some(("candidate", "d/2"))
        );
        assert_eq!(token("vessels/v/fdi/yielded/"), Some(("yielded", "")));
        assert_eq!(token("vessels/v/fdi/alive"), None);
        assert_eq!(token("vessels/v/fdi/"), None);
        assert_eq!(token("vessels/v/steering/holder/x"), None);
    }
}
