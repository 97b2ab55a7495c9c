// The mocked hardware of the doctests on `Node` (each includes this file; it is no module of
// the crate): a CAN controller that keeps what it sends, a settable clock, sensor and actuator,
// and `node()`, agent 2 of Example 1 hearing agent 1 and the leader, stale after 2.5 ms.
pub use agent_node::{Actuator, CanFrame, Clock, Node, NodeConfig, Sensor};
pub use controller_core::ControllerConfig;
use embedded_can::{nb::Can, ErrorKind};

#[derive(Default)]
pub struct Bus {
    pub rx: std::collections::VecDeque<CanFrame>,
    pub tx: Vec<CanFrame>,
}

impl Can for Bus {
    type Frame = CanFrame;
    type Error = ErrorKind;
    fn transmit(&mut self, f: &CanFrame) -> nb::Result<Option<CanFrame>, ErrorKind> {
        self.tx.push(*f);
        Ok(None)
    }
    fn receive(&mut self) -> nb::Result<CanFrame, ErrorKind> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

pub struct Time(pub u64);

impl Clock for Time {
    fn now_us(&mut self) -> u64 {
        self.0
    }
}

pub struct State(pub Result<[f32; 2], ()>);

impl Sensor<2> for State {
    type Error = ();
    fn read(&mut self) -> Result<[f32; 2], ()> {
        self.0
    }
}

#[derive(Default)]
pub struct Drive(pub [f32; 2]);

impl Actuator<2> for Drive {
    type Error = ();
    fn write(&mut self, q: &[f32; 2]) -> Result<(), ()> {
        self.0 = *q;
        Ok(())
    }
}

pub fn node() -> Node<Bus, Time, State, Drive, 2, 2, 1> {
    let ctrl = ControllerConfig::<2> {
        neighbour_count: 1,
        ..Default::default()
    };
    let cfg = NodeConfig::new(2, [1], 2_500);
    Node::new(&cfg, &ctrl, Bus::default(), Time(0), State(Ok([0.1, 0.0])), Drive::default())
        .expect("agent 2 of Example 1")
}
