//! Request parameters: names are case-insensitive (Alpaca API reference §2.2), values
//! come from the query string (GET) or the form-encoded body (PUT).

use crate::errors::Fault;

#[derive(Clone, Debug, Default)]
pub struct Params(Vec<(String, String)>);

impl Params {
    pub fn parse(form: &[u8]) -> Params {
        Params(
            form_urlencoded::parse(form)
                .map(|(k, v)| (k.to_ascii_lowercase(), v.into_owned()))
                .collect(),
        )
    }

    /// The first value given for `name`, whatever its case.
    pub fn get(&self, name: &str) -> Option<&str> {
        let name = name.to_ascii_lowercase();
        self.0
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v.as_str())
    }

    fn need(&self, name: &str) -> Result<&str, Fault> {
        self.get(name)
            .ok_or_else(|| Fault::BadRequest(format!("missing parameter {name}")))
    }

    /// ClientID and ClientTransactionID are unsigned 32-bit; anything else reads as 0.
    pub fn u32_or_zero(&self, name: &str) -> u32 {
        self.get(name)
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0)
    }

    pub fn bool(&self, name: &str) -> Result<bool, Fault> {
        let v = self.need(name)?;
        if v.trim().eq_ignore_ascii_case("true") {
            Ok(true)
        } else if v.trim().eq_ignore_ascii_case("false") {
            Ok(false)
        } else {
            Err(Fault::BadRequest(format!(
                "{name}={v} is not True or False"
            )))
        }
    }

    pub fn i32(&self, name: &str) -> Result<i32, Fault> {
        let v = self.need(name)?;
        v.trim()
            .parse()
            .map_err(|_| Fault::BadRequest(format!("{name}={v} is not a 32-bit integer")))
    }

    /// A number; a non-finite one is a bad value rather than a malformed request.
    pub fn f64(&self, name: &str) -> Result<f64, Fault> {
        let v = self.need(name)?;
        let x: f64 = v
            .trim()
            .parse()
            .map_err(|_| Fault::BadRequest(format!("{name}={v} is not a number")))?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(Fault::invalid_value(format!(
                "{name} must be finite (got {v})"
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_case_insensitive_and_values_decoded() {
        let p = Params::parse(
            b"clientid=7&ClientTransactionID=12&POSITION=-3&Connected=tRuE&Name=a+b%21",
        );
        assert_eq!(p.u32_or_zero("ClientID"), 7);
        assert_eq!(p.u32_or_zero("clienttransactionid"), 12);
        assert_eq!(p.i32("Position"), Ok(-3));
        assert_eq!(p.bool("connected"), Ok(true));
        assert_eq!(p.get("name"), Some("a b!"));
        assert!(matches!(p.i32("Missing"), Err(Fault::BadRequest(_))));
        assert!(matches!(p.bool("Name"), Err(Fault::BadRequest(_))));
        let bad = Params::parse(b"ClientTransactionID=-4&Position=1e400&x=NaN");
        assert_eq!(bad.u32_or_zero("ClientTransactionID"), 0);
        assert!(matches!(
            bad.f64("Position"),
            Err(Fault::Device { number: 0x401, .. })
        ));
        assert!(matches!(
            bad.f64("x"),
            Err(Fault::Device { number: 0x401, .. })
        ));
        assert!(matches!(bad.i32("Position"), Err(Fault::BadRequest(_))));
    }
}
