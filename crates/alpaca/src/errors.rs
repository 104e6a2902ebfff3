//! Alpaca's answers to a failed call: a device error (HTTP 200 with an ASCOM error
//! number) or a malformed request (HTTP 400 with a plain-text reason).

use multistep_controller::CtlError;

/// ASCOM error numbers (Alpaca API reference, "Error handling").
pub mod code {
    pub const NOT_IMPLEMENTED: u16 = 0x400;
    pub const INVALID_VALUE: u16 = 0x401;
    pub const VALUE_NOT_SET: u16 = 0x402;
    pub const NOT_CONNECTED: u16 = 0x407;
    pub const INVALID_OPERATION: u16 = 0x40B;
    pub const ACTION_NOT_IMPLEMENTED: u16 = 0x40C;
    /// First of the driver-specific numbers: the controller refused for its own reason.
    pub const DRIVER: u16 = 0x500;
}

#[derive(Debug, PartialEq)]
pub enum Fault {
    /// HTTP 200, `ErrorNumber` and `ErrorMessage` set.
    Device { number: u16, message: String },
    /// HTTP 400: missing or unparsable parameter, unknown device or method.
    BadRequest(String),
}

impl Fault {
    pub fn device(number: u16, message: impl Into<String>) -> Fault {
        Fault::Device {
            number,
            message: message.into(),
        }
    }
    pub fn not_implemented(what: &str) -> Fault {
        Fault::device(code::NOT_IMPLEMENTED, format!("{what} is not implemented"))
    }
    pub fn invalid_value(message: impl Into<String>) -> Fault {
        Fault::device(code::INVALID_VALUE, message)
    }
    pub fn invalid_operation(message: impl Into<String>) -> Fault {
        Fault::device(code::INVALID_OPERATION, message)
    }
}

/// The controller's refusals in Alpaca's terms; the message is the controller's own.
impl From<CtlError> for Fault {
    fn from(e: CtlError) -> Fault {
        let number = match &e {
            CtlError::OutOfLimits { .. } | CtlError::Syntax(_) => code::INVALID_VALUE,
            CtlError::Busy { .. } | CtlError::EStopped => code::INVALID_OPERATION,
            CtlError::UnknownName { .. } => code::VALUE_NOT_SET,
            _ => code::DRIVER,
        };
        Fault::device(number, e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controller_refusals_map_to_their_ascom_numbers() {
        let num = |e: CtlError| match Fault::from(e) {
            Fault::Device { number, .. } => number,
            f => panic!("{f:?}"),
        };
        let limits = CtlError::OutOfLimits {
            axis: "F".into(),
            target: 9,
            min: "0".into(),
            max: "5".into(),
        };
        assert_eq!(num(limits), 0x401);
        let busy = CtlError::Busy {
            axis: "F".into(),
            state: "homing",
        };
        assert_eq!(num(busy), 0x40B);
        assert_eq!(num(CtlError::EStopped), 0x40B);
        assert_eq!(num(CtlError::Store("disk".into())), 0x500);
    }
}
