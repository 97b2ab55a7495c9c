//! [`BusHost`]: the host's side of a simulated bus that followers sample on — the part of the
//! sample loop that every kind of follower shares, whether the followers are host-compiled
//! nodes on mocked hardware ([`crate::network::CanNetwork`]) or firmware on emulated processors
//! (the processor-in-the-loop kind of `consensus-hil`).
//!
//! Bus node `0` is the leader, bus node `i` is agent `i`. Per sample at time `t` the loop
//!
//! 1. delivers the frames due by `t` ([`BusHost::deliver_until`]): each goes to every other
//!    bus node that is not bus-off at its delivery time and that the caller's filter accepts,
//!    and the sample time at which the sender produced it is recorded per link;
//! 2. lets the followers sample (the caller's part: they submit their frames on
//!    [`BusHost::bus_mut`]);
//! 3. records the age of every value each controller used, `t` minus the sender's recorded
//!    sample time ([`BusHost::link_ages`]), in the bus statistics;
//! 4. submits the leader's `y_d(t)` with its own sequence counter ([`BusHost::send_leader`]).
//!
//! ```
//! use hil_mock::bus::BusConfig;
//! use hil_mock::host::BusHost;
//! use agent_node::wire::IdPlan;
//!
//! // A leader and two agents; agent 1 listens to the leader only, agent 2 to agent 1 only.
//! let mut host = BusHost::new(BusConfig::default(), 2, IdPlan::DEFAULT)?;
//! let heard: [&[usize]; 2] = [&[0], &[1]];
//! let mut ages = [Vec::new(), Vec::new()];
//! for k in 0..10u64 {
//!     let t_ns = k * 1_000_000;
//!     host.deliver_until(t_ns, |j, d| heard[j].contains(&d.from));
//!     for (j, senders) in heard.iter().enumerate() {
//!         host.link_ages(j, t_ns, senders.iter().copied(), &mut ages[j]);
//!     }
//!     host.send_leader(t_ns, 0.5);
//! }
//! // From the second sample on, agent 1 used the leader's value of the previous sample.
//! assert_eq!(ages[0], vec![1_000_000; 9]);
//! assert_eq!(host.sample_time(1, 0), Some(8_000_000));
//! // Agent 2 got nothing: agent 1 never sent (its frames are the caller's to submit).
//! assert!(ages[1].is_empty());
//! assert_eq!(host.bus().stats().frames_delivered, 9);
//! # Ok::<(), hil_mock::bus::BusConfigError>(())
//! ```

use agent_node::wire::{self, IdPlan, Source};

use crate::bus::{Bus, BusConfig, BusConfigError, Delivery, Nanos};
use crate::mock::MockFrame;

/// The simulated bus, the sample time of the latest value on every link, the leader's
/// sequence counter and the identifier plan: what a host loop over followers on a bus owns
/// (module docs).
pub struct BusHost {
    bus: Bus,
    /// `sample_time[receiver][sender]` (bus nodes): sample time of the latest frame delivered.
    sample_time: Vec<Vec<Option<Nanos>>>,
    leader_seq: u8,
    ids: IdPlan,
}

impl BusHost {
    /// A bus of `agents + 1` nodes (the leader and the agents) and no value delivered yet;
    /// the leader's frames carry the identifiers of `ids`.
    pub fn new(config: BusConfig, agents: usize, ids: IdPlan) -> Result<Self, BusConfigError> {
        let n = agents + 1;
        Ok(Self {
            bus: Bus::new(config, n)?,
            sample_time: vec![vec![None; n]; n],
            leader_seq: 0,
            ids,
        })
    }

    /// The bus.
    pub fn bus(&self) -> &Bus {
        &self.bus
    }

    /// The bus (to submit the followers' frames, record a trace: [`Bus::record_wire`]).
    pub fn bus_mut(&mut self) -> &mut Bus {
        &mut self.bus
    }

    /// The identifier plan of the leader's frames.
    pub fn ids(&self) -> &IdPlan {
        &self.ids
    }

    /// Sample time at which bus node `sender` produced the latest frame delivered to bus node
    /// `receiver` (`None`: none yet, or no such node).
    pub fn sample_time(&self, receiver: usize, sender: usize) -> Option<Nanos> {
        self.sample_time
            .get(receiver)?
            .get(sender)
            .copied()
            .flatten()
    }

    /// Runs the bus up to `t_ns` and offers every frame delivered by then, in order, to each
    /// agent `j + 1` (0-based `j`) other than its sender that is not bus-off at the delivery:
    /// `receive(j, delivery)` hands it over and says whether the agent took it. The sample time
    /// of each frame taken is recorded for its link. Returns the deliveries.
    pub fn deliver_until(
        &mut self,
        t_ns: Nanos,
        mut receive: impl FnMut(usize, &Delivery) -> bool,
    ) -> Vec<Delivery> {
        let delivered = self.bus.advance_to(t_ns);
        for d in &delivered {
            for (bus_node, row) in self.sample_time.iter_mut().enumerate().skip(1) {
                if bus_node == d.from || self.bus.is_bus_off(bus_node, d.at_ns) {
                    continue;
                }
                if receive(bus_node - 1, d) {
                    if let Some(slot) = row.get_mut(d.from) {
                        *slot = Some(d.submitted_ns);
                    }
                }
            }
        }
        delivered
    }

    /// The leader (bus node 0) submits `y_d` at `t_ns` with its own sequence counter.
    pub fn send_leader(&mut self, t_ns: Nanos, yd: f32) {
        if let Some((f, _)) =
            wire::encode_in::<MockFrame>(&self.ids, Source::Leader, yd, self.leader_seq)
        {
            // Refusals (silent, bus-off) are counted by the bus.
            let _ = self.bus.submit(0, t_ns, f);
        }
        self.leader_seq = (self.leader_seq + 1) % wire::SEQ_MODULUS;
    }

    /// Agent `j + 1`'s ages at `t_ns` of the values of `senders` (bus nodes, `0` the leader)
    /// its controller uses: `t_ns` minus each sender's sample time, for the links a value was
    /// delivered on. Appended to `ages` and recorded in the bus statistics.
    pub fn link_ages(
        &mut self,
        j: usize,
        t_ns: Nanos,
        senders: impl IntoIterator<Item = usize>,
        ages: &mut Vec<Nanos>,
    ) {
        let Some(row) = self.sample_time.get(j + 1) else {
            return;
        };
        for sender in senders {
            if let Some(ts) = row.get(sender).copied().flatten() {
                let age = t_ns.saturating_sub(ts);
                ages.push(age);
                self.bus.record_age(age);
            }
        }
    }
}
