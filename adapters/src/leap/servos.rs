//! The control tables of a bus of XC330 servos, answering Protocol 2.0 instruction packets as
//! the servos do: pure (bytes in, bytes out), allocation-free once its buffers have grown.
//!
//! Both the LEAP emulator (which moves the present values by its physics) and the virtual
//! Dynamixel bus front (which fills them from a bound device's state and turns goal writes
//! into commands) keep their servos here, so a client sees the same bus either way.
//!
//! Modelled: Ping (unicast and broadcast, in id order), Read, Write, Sync Read (0x82), Fast
//! Sync Read (0x8A), Sync Write (0x83), Reboot; the access rules (read-only items refuse a
//! write with an Access error, EEPROM items below address 64 refuse one while torque is on,
//! an address range past the table a Data Length error... as the e-Manual's status errors);
//! Status Return Level 2 (every unicast instruction is answered). Not modelled: Bulk Read /
//! Write, Reg Write / Action, Factory Reset, Clear, indirect addressing (its items read and
//! write as plain bytes).

use crate::dynamixel::control_table::{reg, Access, Reg};
use crate::dynamixel::protocol::{
    append_status, encode_fast_sync_reply, ErrorNumber, Instruction, PacketRef, StatusError, BROADCAST_ID,
};

use super::control_table::{FIRMWARE_VERSION, XC330_M288_MODEL_NUMBER};

/// Bytes of control table modelled per servo (through Indirect Data 56, address 661).
pub const TABLE_LEN: usize = reg::TABLE_END as usize;

/// What an instruction did besides its replies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Effect {
    /// Some servo's table was written at `[addr, addr + len)` (the last such range; every
    /// written servo is flagged in [`ServoBus::take_written`]).
    pub wrote: Option<(u16, u16)>,
    /// A servo was rebooted.
    pub rebooted: bool,
}

/// Counters of the instructions answered.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BusCounters {
    pub pings: u64,
    pub reads: u64,
    pub writes: u64,
    pub sync_reads: u64,
    pub fast_sync_reads: u64,
    pub sync_writes: u64,
    pub reboots: u64,
    /// Packets that are no instruction these servos take (unknown or unmodelled instruction,
    /// parameters that do not fit its layout, a status packet).
    pub refused: u64,
}

/// One servo's table.
#[derive(Debug, Clone)]
pub struct Servo {
    pub id: u8,
    pub table: Box<[u8; TABLE_LEN]>,
    /// Written since the last [`ServoBus::take_written`].
    written: bool,
}

impl Servo {
    fn new(id: u8) -> Self {
        let mut s = Servo {
            id,
            table: Box::new([0u8; TABLE_LEN]),
            written: false,
        };
        s.factory_defaults();
        s
    }

    /// The e-Manual's initial values of the items handgate or a LEAP client touches.
    fn factory_defaults(&mut self) {
        self.table.fill(0);
        self.put(reg::MODEL_NUMBER, i64::from(XC330_M288_MODEL_NUMBER));
        self.put(reg::FIRMWARE_VERSION, i64::from(FIRMWARE_VERSION));
        self.put(reg::ID, i64::from(self.id));
        self.put(reg::BAUD_RATE, 1);
        self.put(reg::RETURN_DELAY_TIME, 250);
        self.put(reg::PROTOCOL_VERSION, 2);
        self.put(reg::OPERATING_MODE, 3);
        self.put(reg::TEMPERATURE_LIMIT, 70);
        self.put(reg::MAX_VOLTAGE_LIMIT, 70);
        self.put(reg::MIN_VOLTAGE_LIMIT, 35);
        self.put(reg::PWM_LIMIT, 885);
        self.put(reg::CURRENT_LIMIT, 1750);
        self.put(reg::VELOCITY_LIMIT, 445);
        self.put(reg::MAX_POSITION_LIMIT, 4095);
        self.put(reg::MIN_POSITION_LIMIT, 0);
        self.put(reg::SHUTDOWN, 52);
        self.ram_defaults();
    }

    fn ram_defaults(&mut self) {
        self.put(reg::TORQUE_ENABLE, 0);
        self.put(reg::STATUS_RETURN_LEVEL, 2);
        self.put(reg::POSITION_P_GAIN, 400);
        self.put(reg::POSITION_I_GAIN, 0);
        self.put(reg::POSITION_D_GAIN, 0);
        self.put(reg::GOAL_CURRENT, 1750);
        self.put(reg::PRESENT_INPUT_VOLTAGE, 50);
        self.put(reg::PRESENT_TEMPERATURE, 30);
    }

    /// Item `r` (little-endian, sign-extended from its size).
    pub fn get(&self, r: Reg) -> i64 {
        let a = r.addr as usize;
        let b = &self.table[a..a + r.len as usize];
        match r.len {
            1 => i64::from(b[0]),
            2 => i64::from(i16::from_le_bytes([b[0], b[1]])),
            _ => i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        }
    }

    /// Sets item `r` (truncated to its size).
    pub fn put(&mut self, r: Reg, v: i64) {
        let a = r.addr as usize;
        let n = r.len as usize;
        self.table[a..a + n].copy_from_slice(&v.to_le_bytes()[..n]);
    }

    pub fn torque_on(&self) -> bool {
        self.table[reg::TORQUE_ENABLE.addr as usize] != 0
    }

    fn read_range(&self, addr: u16, len: u16) -> Result<&[u8], ErrorNumber> {
        let (a, n) = (addr as usize, len as usize);
        if n == 0 || a + n > TABLE_LEN {
            return Err(ErrorNumber::DataLengthError);
        }
        Ok(&self.table[a..a + n])
    }

    /// A write as the servo takes it: refused whole when any byte is read-only or EEPROM
    /// under torque, or past the table.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<(), ErrorNumber> {
        let (a, n) = (addr as usize, data.len());
        if n == 0 || a + n > TABLE_LEN {
            return Err(ErrorNumber::DataLengthError);
        }
        let end = addr + n as u16;
        for r in reg::ALL {
            let overlaps = r.addr < end && addr < r.addr + r.len;
            if overlaps && r.access == Access::ReadOnly {
                return Err(ErrorNumber::AccessError);
            }
        }
        if addr < reg::RAM_START && self.torque_on() {
            return Err(ErrorNumber::AccessError);
        }
        self.table[a..a + n].copy_from_slice(data);
        self.written = true;
        Ok(())
    }
}

/// The servos of one bus.
#[derive(Debug, Clone)]
pub struct ServoBus {
    pub servos: Vec<Servo>,
    pub counters: BusCounters,
    /// Where a Fast Sync Read reply is built (its buffer reused).
    scratch: Vec<u8>,
}

impl ServoBus {
    /// Servos `ids` at their factory defaults.
    pub fn new(ids: &[u8]) -> Self {
        Self {
            servos: ids.iter().map(|&id| Servo::new(id)).collect(),
            counters: BusCounters::default(),
            scratch: Vec::new(),
        }
    }

    /// The servo with `id`.
    pub fn servo(&self, id: u8) -> Option<&Servo> {
        self.servos.iter().find(|s| s.id == id)
    }

    pub fn servo_mut(&mut self, id: u8) -> Option<&mut Servo> {
        self.servos.iter_mut().find(|s| s.id == id)
    }

    fn index(&self, id: u8) -> Option<usize> {
        self.servos.iter().position(|s| s.id == id)
    }

    /// Calls `f` with the index of every servo written since the last call, and clears the
    /// flags.
    pub fn take_written(&mut self, mut f: impl FnMut(usize, &Servo)) {
        for (i, s) in self.servos.iter_mut().enumerate() {
            if std::mem::take(&mut s.written) {
                f(i, s);
            }
        }
    }

    /// Answers the instruction packet `pk`: appends every status the servos send to `out` (in
    /// line order). The caller refreshes the present values before (a read answers what the
    /// table holds) and looks at [`Effect`] after.
    pub fn answer(&mut self, pk: PacketRef<'_>, out: &mut Vec<u8>) -> Effect {
        let mut effect = Effect::default();
        let p = pk.params;
        let u16_at = |i: usize| u16::from_le_bytes([p[i], p[i + 1]]);
        let Some(inst) = Instruction::from_byte(pk.instruction) else {
            self.counters.refused += 1;
            return effect;
        };
        let unicast = pk.id != BROADCAST_ID;
        match inst {
            Instruction::Ping if p.is_empty() => {
                self.counters.pings += 1;
                for s in &self.servos {
                    if pk.id == BROADCAST_ID || pk.id == s.id {
                        let [lo, hi] = XC330_M288_MODEL_NUMBER.to_le_bytes();
                        let fw = s.table[reg::FIRMWARE_VERSION.addr as usize];
                        let _ = append_status(out, s.id, StatusError::OK, &[lo, hi, fw]);
                    }
                }
            }
            Instruction::Read if p.len() == 4 && unicast => {
                self.counters.reads += 1;
                if let Some(s) = self.servo(pk.id) {
                    reply_read(out, s, u16_at(0), u16_at(2));
                }
            }
            Instruction::Write if p.len() >= 3 => {
                self.counters.writes += 1;
                let addr = u16_at(0);
                for s in self.servos.iter_mut().filter(|s| !unicast || s.id == pk.id) {
                    let r = s.write(addr, &p[2..]);
                    if r.is_ok() {
                        effect.wrote = Some((addr, (p.len() - 2) as u16));
                    }
                    if unicast {
                        let _ = append_status(out, s.id, error(r.err()), &[]);
                    }
                }
            }
            Instruction::Reboot if p.is_empty() => {
                self.counters.reboots += 1;
                for s in self.servos.iter_mut().filter(|s| !unicast || s.id == pk.id) {
                    s.ram_defaults();
                    effect.rebooted = true;
                    if unicast {
                        let _ = append_status(out, s.id, StatusError::OK, &[]);
                    }
                }
            }
            Instruction::SyncRead if p.len() >= 4 && !unicast => {
                self.counters.sync_reads += 1;
                let (addr, len) = (u16_at(0), u16_at(2));
                for &id in &p[4..] {
                    if let Some(s) = self.servo(id) {
                        reply_read(out, s, addr, len);
                    }
                }
            }
            Instruction::FastSyncRead if p.len() >= 5 && !unicast => {
                self.counters.fast_sync_reads += 1;
                let (addr, len) = (u16_at(0), u16_at(2));
                let ids = &p[4..];
                // Every listed servo must be on the bus and the range readable: a real bus
                // answers with a chain broken where a servo is missing, which no client can
                // parse; nothing is sent then (the client times out, as on a real bus).
                if ids.iter().all(|&id| self.servo(id).is_some())
                    && (len as usize) > 0
                    && addr as usize + len as usize <= TABLE_LEN
                {
                    let servos = &self.servos;
                    let ok = encode_fast_sync_reply(ids.len(), len as usize, &mut self.scratch, |i, d| {
                        let s = servos.iter().find(|s| s.id == ids[i]).expect("checked above");
                        d.copy_from_slice(&s.table[addr as usize..addr as usize + len as usize]);
                        (s.id, StatusError::OK)
                    });
                    if ok.is_ok() {
                        out.extend_from_slice(&self.scratch);
                    }
                }
            }
            Instruction::SyncWrite if p.len() >= 4 && !unicast => {
                self.counters.sync_writes += 1;
                let (addr, len) = (u16_at(0), u16_at(2) as usize);
                if len == 0 || (p.len() - 4) % (len + 1) != 0 {
                    self.counters.refused += 1;
                    return effect;
                }
                for chunk in p[4..].chunks(len + 1) {
                    if let Some(i) = self.index(chunk[0]) {
                        if self.servos[i].write(addr, &chunk[1..]).is_ok() {
                            effect.wrote = Some((addr, len as u16));
                        }
                    }
                }
            }
            _ => self.counters.refused += 1,
        }
        effect
    }
}

fn error(e: Option<ErrorNumber>) -> StatusError {
    StatusError {
        alert: false,
        number: e.unwrap_or(ErrorNumber::None),
    }
}

fn reply_read(out: &mut Vec<u8>, s: &Servo, addr: u16, len: u16) {
    let _ = match s.read_range(addr, len) {
        Ok(d) => append_status(out, s.id, StatusError::OK, d),
        Err(e) => append_status(out, s.id, error(Some(e)), &[]),
    };
}
