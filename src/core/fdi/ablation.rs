//! Switches that turn one mechanism of the decision off, for `eval --fdi --ablate` only.
//!
//! The ablation measures what each mechanism buys: the suites run once as built and once
//! with each mechanism off. A switch is process-wide (the suites run many ships on many
//! threads, each through the whole decision) and off by default; the daemon, the probe,
//! replay and every test leave it so. Each mechanism's doc says what "off" means: the
//! simplest rule that still decides.

use std::sync::atomic::{AtomicU32, Ordering};

/// A mechanism the ablation can switch off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mechanism {
    /// Off: the estimator's bias and spread of a moderate sea whatever the test's wave yaw.
    SeaInterpolation,
    /// Off: no extra network evaluations; the speed log's direction is `(-1, 0, 0)`, the
    /// displacement's `(0, 1, 0.01)`, the similarity slopes zero.
    NetworkSlopes,
    /// Off: HBT's displacement direction from the first-order harmonic balance, not the
    /// vessel's measured CLFRT response.
    LoopShape,
    /// Off: a CLFRT test is read with the vessel's typical error only, not its own.
    OwnNoise,
    /// Off: the design's reference for good (`fdi.commissioning-tests = 0`).
    VesselReference,
    /// Off: no slopes over the operating point: the offset at a point is the kernel-weighted
    /// mean of the learned tests.
    EnvelopeSlopes,
    /// Off: one pass of the scatter's shape (no fixed point).
    ShapeFixedPoint,
    /// Off: the whitened residual is not mapped from Hotelling's tail onto the chi-square's.
    HotellingCalibration,
    /// Off: no change-point test of the commissioning sample.
    ChangePoint,
    /// Off: no confirmation of the learned tests.
    Confirmation,
    /// Off: no limit, noise or typicality gate on learning (an alert still holds a test for
    /// the window).
    LearningGate,
    /// Off: no test is learned after commissioning (the commissioning sample alone,
    /// predicted over the envelope).
    Learning,
    /// Off: each test decided alone (`fdi.window-tests = 1`).
    WindowGlr,
    /// Off: no servo channel (the rudder's rate never decides).
    ServoChannel,
    /// Off: the cause named is the one with the lower cost, without its chi-square tail.
    IsolationTails,
    /// Off: no step of the speed log between tests.
    LogStep,
    /// Off: the alert limit is the alarm's.
    AlertLevel,
    /// Off: no gain residual `e_b` (two residuals, `e_u` and `e_D`).
    GainChannel,
}

impl Mechanism {
    /// Every mechanism, in the order of a test's evidence.
    pub const ALL: [Mechanism; 18] = [
        Mechanism::SeaInterpolation,
        Mechanism::NetworkSlopes,
        Mechanism::GainChannel,
        Mechanism::LoopShape,
        Mechanism::OwnNoise,
        Mechanism::VesselReference,
        Mechanism::EnvelopeSlopes,
        Mechanism::ShapeFixedPoint,
        Mechanism::HotellingCalibration,
        Mechanism::ChangePoint,
        Mechanism::Confirmation,
        Mechanism::Learning,
        Mechanism::LearningGate,
        Mechanism::WindowGlr,
        Mechanism::AlertLevel,
        Mechanism::ServoChannel,
        Mechanism::IsolationTails,
        Mechanism::LogStep,
    ];

    /// Its name on the command line and in the table.
    pub fn name(self) -> &'static str {
        match self {
            Mechanism::SeaInterpolation => "sea-interpolation",
            Mechanism::NetworkSlopes => "network-slopes",
            Mechanism::LoopShape => "loop-shape",
            Mechanism::OwnNoise => "own-noise",
            Mechanism::VesselReference => "vessel-reference",
            Mechanism::EnvelopeSlopes => "envelope-slopes",
            Mechanism::ShapeFixedPoint => "shape-fixed-point",
            Mechanism::HotellingCalibration => "hotelling-calibration",
            Mechanism::ChangePoint => "change-point",
            Mechanism::Confirmation => "confirmation",
            Mechanism::LearningGate => "learning-gate",
            Mechanism::Learning => "learning",
            Mechanism::WindowGlr => "window-glr",
            Mechanism::ServoChannel => "servo-channel",
            Mechanism::IsolationTails => "isolation-tails",
            Mechanism::LogStep => "log-step",
            Mechanism::AlertLevel => "alert-level",
            Mechanism::GainChannel => "gain-channel",
        }
    }

    fn bit(self) -> u32 {
        1 << (self as u32)
    }
}

static OFF: AtomicU32 = AtomicU32::new(0);

/// Is `m` switched off?
pub fn off(m: Mechanism) -> bool {
    OFF.load(Ordering::Relaxed) & m.bit() != 0
}

/// Switches `m` off (`Some`) or every mechanism back on (`None`). For the ablation only.
pub fn switch_off(m: Option<Mechanism>) {
    OFF.store(m.map_or(0, Mechanism::bit), Ordering::Relaxed);
}
