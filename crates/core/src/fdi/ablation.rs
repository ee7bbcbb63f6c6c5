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
    /// displacement's the class's measured one or `(0, 1, 0.01)`, the similarity slopes
    /// zero.
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
    /// Off: the whitened residual is not mapped from Hotelling's tail onto the chi-square's.
    HotellingCalibration,
    /// Off: no class prior for the scatter: the vessel's own tests alone (Hotelling-wide
    /// after a few).
    ClassPrior,
    /// Off: no test of the commissioning sample for a change inside it, neither when it
    /// completes nor as the tests after it are learned.
    CommissioningCheck,
    /// Off: each method's commissioning ends on its own sample's resolution (or at `K`),
    /// not on the vessel's other method's (`reference::complete_on_other`).
    OneResolved,
    /// Off: no test is learned after commissioning (the commissioning sample alone,
    /// predicted over the envelope).
    Learning,
    /// Off: each test decided alone (`fdi.window-tests = 1`).
    WindowGlr,
    /// Off: no servo channel (the rudder's rate never decides).
    ServoChannel,
    /// Off: no step of the speed log between tests.
    LogStep,
    /// Off: the alert limit is the alarm's.
    AlertLevel,
    /// Off: no gain residual `e_b` (two residuals, `e_u` and `e_D`).
    GainChannel,
    /// Off: the displacement's direction is the `b` scaling's and the speed's slope the
    /// similarity law's at each test, not the class's measured ones (`calibration.json`'s
    /// `displacement-direction`, `speed-slope`).
    ClassDirection,
}

impl Mechanism {
    /// Every mechanism, in the order of a test's evidence.
    pub const ALL: [Mechanism; 17] = [
        Mechanism::SeaInterpolation,
        Mechanism::NetworkSlopes,
        Mechanism::GainChannel,
        Mechanism::ClassDirection,
        Mechanism::LoopShape,
        Mechanism::OwnNoise,
        Mechanism::VesselReference,
        Mechanism::EnvelopeSlopes,
        Mechanism::HotellingCalibration,
        Mechanism::ClassPrior,
        Mechanism::OneResolved,
        Mechanism::CommissioningCheck,
        Mechanism::Learning,
        Mechanism::WindowGlr,
        Mechanism::AlertLevel,
        Mechanism::ServoChannel,
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
            Mechanism::HotellingCalibration => "hotelling-calibration",
            Mechanism::ClassPrior => "class-prior",
            Mechanism::OneResolved => "one-resolved",
            Mechanism::CommissioningCheck => "commissioning-check",
            Mechanism::Learning => "learning",
            Mechanism::WindowGlr => "window-glr",
            Mechanism::ServoChannel => "servo-channel",
            Mechanism::LogStep => "log-step",
            Mechanism::AlertLevel => "alert-level",
            Mechanism::GainChannel => "gain-channel",
            Mechanism::ClassDirection => "class-direction",
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

/// Switches the mechanisms in `set` off and every other one on (an empty set: all on). For
/// the ablation only.
pub fn switch_off(set: &[Mechanism]) {
    OFF.store(set.iter().fold(0, |b, m| b | m.bit()), Ordering::Relaxed);
}
