//! The ship's samples: the payloads of the input streams and their decoding.

use super::Stream;
use serde::{Deserialize, Serialize};

/// `{"t": f64, "value": f64}`: heading, rudder, speed, target heading.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Scalar {
    /// Ship time [s].
    pub t: f64,
    /// Value in SI units (rad or m/s).
    pub value: f64,
}

/// `{"t": f64, "value": "auto" | "standby" | ...}`: autopilot state.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct StateValue {
    /// Ship time [s].
    pub t: f64,
    /// Signal K autopilot state.
    pub value: String,
}

/// A decoded sample of one input stream.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// True heading [rad].
    Heading(Scalar),
    /// Rudder angle [rad].
    Rudder(Scalar),
    /// Speed through water [m/s].
    Speed(Scalar),
    /// Autopilot state.
    AutopilotState(StateValue),
    /// Autopilot target heading [rad].
    TargetHeading(Scalar),
    /// Design displacement [kg] (Signal K `design.displacement`).
    DesignDisplacement(Scalar),
}

impl Input {
    /// The stream this sample belongs to.
    pub fn stream(&self) -> Stream {
        match self {
            Input::Heading(_) => Stream::Heading,
            Input::Rudder(_) => Stream::Rudder,
            Input::Speed(_) => Stream::Speed,
            Input::AutopilotState(_) => Stream::AutopilotState,
            Input::TargetHeading(_) => Stream::TargetHeading,
            Input::DesignDisplacement(_) => Stream::DesignDisplacement,
        }
    }
    /// Ship time of the sample [s].
    pub fn t(&self) -> f64 {
        match self {
            Input::Heading(s)
            | Input::Rudder(s)
            | Input::Speed(s)
            | Input::TargetHeading(s)
            | Input::DesignDisplacement(s) => s.t,
            Input::AutopilotState(s) => s.t,
        }
    }
    /// The JSON payload of this sample, as a ship publishes it.
    pub fn payload(&self) -> serde_json::Value {
        let r = match self {
            Input::Heading(s)
            | Input::Rudder(s)
            | Input::Speed(s)
            | Input::TargetHeading(s)
            | Input::DesignDisplacement(s) => serde_json::to_value(s),
            Input::AutopilotState(s) => serde_json::to_value(s),
        };
        r.unwrap_or(serde_json::Value::Null)
    }
}

/// Why a payload was not accepted as an input sample.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// Not JSON, or not of the payload's shape.
    #[error("malformed payload: {0}")]
    Malformed(String),
}

/// Decodes the payload of `stream` from JSON bytes. Only the shape is checked here; values
/// (finiteness, ranges, time order) are checked by the monitor, which counts rejections.
pub fn decode(stream: Stream, bytes: &[u8]) -> Result<Input, DecodeError> {
    let m = |e: serde_json::Error| DecodeError::Malformed(e.to_string());
    Ok(match stream {
        Stream::Heading => Input::Heading(serde_json::from_slice(bytes).map_err(m)?),
        Stream::Rudder => Input::Rudder(serde_json::from_slice(bytes).map_err(m)?),
        Stream::Speed => Input::Speed(serde_json::from_slice(bytes).map_err(m)?),
        Stream::AutopilotState => Input::AutopilotState(serde_json::from_slice(bytes).map_err(m)?),
        Stream::TargetHeading => Input::TargetHeading(serde_json::from_slice(bytes).map_err(m)?),
        Stream::DesignDisplacement => {
            Input::DesignDisplacement(serde_json::from_slice(bytes).map_err(m)?)
        }
    })
}

/// Decodes a payload already parsed as JSON (recordings).
pub fn decode_value(stream: Stream, v: serde_json::Value) -> Result<Input, DecodeError> {
    let m = |e: serde_json::Error| DecodeError::Malformed(e.to_string());
    Ok(match stream {
        Stream::Heading => Input::Heading(serde_json::from_value(v).map_err(m)?),
        Stream::Rudder => Input::Rudder(serde_json::from_value(v).map_err(m)?),
        Stream::Speed => Input::Speed(serde_json::from_value(v).map_err(m)?),
        Stream::AutopilotState => Input::AutopilotState(serde_json::from_value(v).map_err(m)?),
        Stream::TargetHeading => Input::TargetHeading(serde_json::from_value(v).map_err(m)?),
        Stream::DesignDisplacement => {
            Input::DesignDisplacement(serde_json::from_value(v).map_err(m)?)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_payload_is_an_error_not_a_panic() {
        assert!(decode(Stream::Heading, b"{\"t\": 1.0}").is_err());
        assert!(decode(Stream::Heading, b"not json").is_err());
        assert!(decode(Stream::AutopilotState, b"{\"t\": 1.0, \"value\": 3}").is_err());
        let ok = decode(Stream::Heading, br#"{"t": 1.0, "value": 0.5}"#).unwrap();
        assert_eq!(ok.t(), 1.0);
    }
}
