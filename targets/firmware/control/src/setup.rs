//! What an image takes from its rig's model file and its line of `variants.txt`, as a board
//! needs it in production: computed by the build script (`hapticgen_fw_build`), which emits a
//! `setup()` returning a [`Setup`] for the image's rig.

use hapticgen_runtime::current_loop::CurrentLoopGains;

/// Model-derived settings of one image (`N` joints, scalar `S`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup<S, const N: usize> {
    /// Each joint's current-loop gains, designed from its motor by the model loader
    /// (`hapticgen_codegen::check::current_loop::design_current_loop`; the generated
    /// `CURRENT_LOOP_GAINS`), for `HapticLoopSettings::current_gains`.
    pub current_gains: [CurrentLoopGains<S>; N],
    /// Start pose (the `pose` column of `variants.txt`), rad or m: where the device is homed.
    pub start: [S; N],
    /// Free-space grid spacing (m), wall stiffness (N/m) and damping (N·s/m) from the model's
    /// `rendering:` section, if it has one.
    pub rendering: Option<[S; 3]>,
}
