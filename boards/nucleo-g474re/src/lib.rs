//! The board-independent logic of the NUCLEO-G474RE node firmware, apart from its registers so
//! that it runs on the host: `cargo test --lib --target x86_64-unknown-linux-gnu` in this
//! directory (the firmware itself, `src/main.rs`, builds only for `thumbv7em-none-eabihf`).
//!
//! * [`board`]: the decisions around each `Node::tick`, as the control task runs them;
//! * [`gate`]: when the motor driver may be enabled (the output gate), the run command, the
//!   freshness of a value counted in samples;
//! * [`scale`]: encoder counts to `x_i`, commands to PWM duty;
//! * [`can_setup`]: the FDCAN1 bit timing and acceptance filters as register words;
//! * [`bus_off`]: bus-off recovery (ISO 11898-1: 128 × 11 recessive bits), counted;
//! * [`iwdg`]: the independent watchdog's prescaler and reload for a timeout;
//! * [`reset`]: the reset cause (`RCC_CSR`) and the boot count (backup register) for the
//!   heartbeat;
//! * [`bench`]: sensor and actuator over `agent_node::plant_bus` frames (feature `bench`);
//! * [`param_page`]: the stored configuration's flash page (CANopen store/restore) and the
//!   boot decision (node-ID, stored parameters or the defaults);
//! * [`config`]: the compiled-in defaults and the agent plan.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bench;
pub mod board;
pub mod bus_off;
pub mod can_setup;
pub mod config;
pub mod gate;
pub mod iwdg;
pub mod param_page;
pub mod reset;
pub mod scale;

#[cfg(test)]
mod tests {
    use crate::{config, iwdg};

    #[test]
    fn the_shipped_wiring_is_accepted_and_its_watchdog_is_five_samples() {
        assert_eq!(config::wiring_error(), None);
        let s = iwdg::IwdgSetting::for_timeout(config::WATCHDOG_US, iwdg::LSI_HZ).expect("fits");
        assert_eq!(s, iwdg::IwdgSetting { pr: 0, rl: 39 });
        assert_eq!(
            s.timeout_us(iwdg::LSI_HZ),
            5 * u64::from(config::SAMPLE_PERIOD_US)
        );
    }
}
