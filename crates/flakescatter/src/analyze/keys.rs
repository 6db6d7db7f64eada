//! The manifest values with more than one form, read by hand rather than by serde's
//! untagged enums (whose error is only "data did not match any variant"): a value of
//! neither form, a range with a key missing or unknown, a list holding a non-number,
//! is an error naming the key and the accepted forms; the TOML reader adds the line
//! and column.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};

use super::manifest::{Angles, ChannelKey};

/// The accepted forms of `models.theta_s_deg`.
const ANGLE_FORMS: &str = "`models.theta_s_deg` is a list of angles in degrees (`theta_s_deg = [-70, -45, 0, 45]`) or an inclusive range with all three keys (`theta_s_deg = { from = -70, to = 70, step = 0.5 }`)";

struct AnglesVisitor;

impl<'de> Visitor<'de> for AnglesVisitor {
    type Value = Angles;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(ANGLE_FORMS)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Angles, A::Error> {
        let mut v = Vec::new();
        loop {
            match seq.next_element::<f64>() {
                Ok(Some(x)) => v.push(x),
                Ok(None) => return Ok(Angles::List(v)),
                Err(_) => {
                    return Err(de::Error::custom(format!(
                        "angle {} of the list is not a number; {ANGLE_FORMS}",
                        v.len() + 1
                    )));
                }
            }
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Angles, A::Error> {
        let (mut from, mut to, mut step) = (None, None, None);
        while let Some(key) = map.next_key::<String>()? {
            let slot = match key.as_str() {
                "from" => &mut from,
                "to" => &mut to,
                "step" => &mut step,
                other => {
                    return Err(de::Error::custom(format!(
                        "the range has an unknown key `{other}`; {ANGLE_FORMS}"
                    )));
                }
            };
            let value: f64 = map.next_value().map_err(|_| {
                de::Error::custom(format!(
                    "the range's `{key}` is not a number (degrees); {ANGLE_FORMS}"
                ))
            })?;
            *slot = Some(value);
        }
        let missing: Vec<&str> = [("from", from), ("to", to), ("step", step)]
            .iter()
            .filter(|(_, v)| v.is_none())
            .map(|(k, _)| *k)
            .collect();
        match (from, to, step) {
            (Some(from), Some(to), Some(step)) => Ok(Angles::Range { from, to, step }),
            _ => Err(de::Error::custom(format!(
                "the range lacks {}; {ANGLE_FORMS}",
                missing
                    .iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(" and ")
            ))),
        }
    }
}

impl<'de> Deserialize<'de> for Angles {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(AnglesVisitor)
    }
}

/// The accepted forms of a channel key.
const CHANNEL_FORMS: &str = "a channel (`maps.channel`, `maps.intensity_channel`) is an index from 0 (`channel = 0`) or a name as `flakescatter info` lists it (`channel = \"layer0\"`)";

struct ChannelVisitor;

impl Visitor<'_> for ChannelVisitor {
    type Value = ChannelKey;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(CHANNEL_FORMS)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<ChannelKey, E> {
        usize::try_from(v)
            .map(ChannelKey::Index)
            .map_err(|_| E::custom(format!("{v} is not a channel index; {CHANNEL_FORMS}")))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<ChannelKey, E> {
        usize::try_from(v)
            .map(ChannelKey::Index)
            .map_err(|_| E::custom(format!("{v} is not a channel index; {CHANNEL_FORMS}")))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<ChannelKey, E> {
        Ok(ChannelKey::Name(v.to_owned()))
    }
}

impl<'de> Deserialize<'de> for ChannelKey {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ChannelVisitor)
    }
}

#[cfg(test)]
mod tests {
    use crate::analyze::Manifest;

    const HEAD: &str = "[maps]\nfiles = [\"a.x3p\"]\n";

    fn err(tail: &str) -> String {
        Manifest::from_toml(&format!("{HEAD}{tail}"), "m.toml")
            .unwrap_err()
            .to_string()
    }

    /// A range without `step` (issue 52, item 22), with an unknown key, a list with a
    /// non-number, a lone number: each names the key, the line and the accepted forms.
    #[test]
    fn angle_values_of_neither_form_name_the_key_line_and_forms() {
        let line = "line 5";
        for (value, needle) in [
            ("{ from = -70, to = 70 }", "lacks `step`"),
            ("{ from = -70 }", "lacks `to` and `step`"),
            (
                "{ from = -70, to = 70, step = 1, stride = 2 }",
                "unknown key `stride`",
            ),
            (
                "{ from = -70, to = \"70\", step = 1 }",
                "`to` is not a number",
            ),
            ("[1, \"a\"]", "angle 2 of the list is not a number"),
            ("-5", "invalid type"),
            ("\"x\"", "invalid type"),
        ] {
            let e = err(&format!("[models]\nfit = false\ntheta_s_deg = {value}\n"));
            for n in [
                needle,
                line,
                "`models.theta_s_deg`",
                "step = 0.5 }",
                "m.toml",
            ] {
                assert!(e.contains(n), "{n:?} not in: {e}");
            }
            assert!(!e.contains("did not match any variant"), "{e}");
        }
        // The accepted forms still read.
        for value in ["{ from = -70, to = 70, step = 0.5 }", "[-70, 0, 45.5]"] {
            let t = format!("{HEAD}[models]\nfit = false\ntheta_s_deg = {value}\n");
            assert!(Manifest::from_toml(&t, "m.toml").is_ok(), "{value}");
        }
    }

    /// A channel that is neither an index nor a name names the accepted forms.
    #[test]
    fn channel_values_of_neither_form_name_the_forms() {
        for (value, needle) in [
            ("-1", "-1 is not a channel index"),
            ("1.5", "invalid type"),
            ("true", "invalid type"),
        ] {
            let e = err(&format!("channel = {value}\n"));
            for n in [needle, "line 3", "index from 0", "m.toml"] {
                assert!(e.contains(n), "{n:?} not in: {e}");
            }
        }
        for value in ["0", "\"layer0\"", "\"2\""] {
            let t = format!("{HEAD}channel = {value}\n[models]\nfit = false\n");
            assert!(Manifest::from_toml(&t, "m.toml").is_ok(), "{value}");
        }
    }
}
