//! [`answer`] / [`respond`] against a [`Bank`]: every function, the exceptions the spec
//! assigns, FC23's write-before-read, the silent option.

use super::pdu::*;
use super::server::{answer, respond, Bank, Outcome, RegisterMap};

fn bank() -> Bank {
    Bank {
        holding_base: 1000,
        holding: (0..10).map(|i| 100 + i).collect(),
        input_base: 2000,
        input: (0..6).map(|i| 0x0700 + i).collect(),
    }
}

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

fn run(map: &mut Bank, pdu: &str, exceptions: bool) -> (Outcome, Vec<u8>) {
    let mut out = Vec::new();
    let o = respond(map, &hex(pdu), exceptions, &mut out, &mut |_| {});
    (o, out)
}

#[test]
fn reads_come_from_their_table() {
    let mut b = bank();
    // FC03 of 1002..1004.
    let (o, out) = run(&mut b, "03 03 EA 00 03", true);
    assert_eq!(o, Outcome::Answered);
    assert_eq!(out, hex("03 06 00 66 00 67 00 68"));
    // FC04 of 2000..2001.
    let (_, out) = run(&mut b, "04 07 D0 00 02", true);
    assert_eq!(out, hex("04 04 07 00 07 01"));
    // FC03 at the input table's address: not a holding register.
    let (o, out) = run(&mut b, "03 07 D0 00 01", true);
    assert_eq!(
        o,
        Outcome::Exception {
            function: READ_HOLDING,
            code: Exception::IllegalDataAddress
        }
    );
    assert_eq!(out, hex("83 02"));
}

#[test]
fn writes_echo_and_change_the_registers() {
    let mut b = bank();
    let (o, out) = run(&mut b, "06 03 E8 12 34", true);
    assert_eq!((o, out), (Outcome::Answered, hex("06 03 E8 12 34")));
    assert_eq!(b.holding[0], 0x1234);
    let (_, out) = run(&mut b, "10 03 E9 00 02 04 AB CD 00 01", true);
    assert_eq!(out, hex("10 03 E9 00 02"));
    assert_eq!(&b.holding[..4], &[0x1234, 0xABCD, 0x0001, 103]);
}

#[test]
fn fc23_writes_before_it_reads() {
    let mut b = bank();
    // Write 2 registers at 1000, read 1000..1002: the read sees the write.
    let (o, out) = run(&mut b, "17 03 E8 00 03 03 E8 00 02 04 00 01 00 02", true);
    assert_eq!(o, Outcome::Answered);
    assert_eq!(out, hex("17 06 00 01 00 02 00 66"));
}

#[test]
fn out_of_range_is_exception_2_and_changes_nothing() {
    let mut b = bank();
    let before = b.clone();
    for pdu in [
        "03 03 E7 00 01",                      // below the bank
        "03 03 F1 00 02",                      // past its end
        "10 03 F1 00 02 04 00 00 00 00",       // write past the end
        "06 00 00 00 01",                      // single write outside
        "17 03 E8 00 01 03 F2 00 01 02 00 00", // FC23 write outside: no read either
        "03 FF FF 00 02",                      // wraps past 0xFFFF
        "17 FF FF 00 02 03 E8 00 01 02 00 09", // FC23 read wraps: nothing written
    ] {
        let (o, out) = run(&mut b, pdu, true);
        assert!(
            matches!(
                o,
                Outcome::Exception {
                    code: Exception::IllegalDataAddress,
                    ..
                }
            ),
            "{pdu}: {o:?}"
        );
        assert_eq!(out[1], 2, "{pdu}");
        assert_eq!(out[0], hex(pdu)[0] | EXCEPTION_BIT, "{pdu}");
        assert_eq!(b, before, "{pdu} changed the bank");
    }
}

#[test]
fn unknown_functions_and_bad_quantities() {
    let mut b = bank();
    // FC01 read coils: not supported.
    let (o, out) = run(&mut b, "01 00 00 00 08", true);
    assert_eq!(
        o,
        Outcome::Exception {
            function: 1,
            code: Exception::IllegalFunction
        }
    );
    assert_eq!(out, hex("81 01"));
    // 126 registers.
    let (_, out) = run(&mut b, "03 03 E8 00 7E", true);
    assert_eq!(out, hex("83 03"));
    // Byte count that is not twice the quantity.
    let (_, out) = run(&mut b, "10 03 E8 00 01 04 00 00 00 00", true);
    assert_eq!(out, hex("90 03"));
    // Nothing to answer to.
    assert_eq!(run(&mut b, "", true), (Outcome::Ignored, vec![]));
}

#[test]
fn a_silent_device_sends_nothing_but_says_why() {
    let mut b = bank();
    let (o, out) = run(&mut b, "03 00 00 00 01", false);
    assert_eq!(
        o,
        Outcome::Silent {
            function: READ_HOLDING,
            code: Exception::IllegalDataAddress
        }
    );
    assert!(out.is_empty());
    assert_eq!(o.reason(), Some("illegal_address"));
    let (o, out) = run(&mut b, "2B 0E 01 00", false);
    assert_eq!(o.reason(), Some("illegal_function"));
    assert!(out.is_empty());
    // Normal requests are answered as usual.
    let (o, out) = run(&mut b, "03 03 E8 00 01", false);
    assert_eq!((o, out), (Outcome::Answered, hex("03 02 00 64")));
}

#[test]
fn decoded_requests_are_handed_over_before_they_are_performed() {
    struct Refuses;
    impl RegisterMap for Refuses {
        fn read(&mut self, _: Table, _: u16, _: &mut [u16]) -> Result<(), Exception> {
            Err(Exception::ServerDeviceFailure)
        }
        fn write(&mut self, _: u16, _: Regs<'_>) -> Result<(), Exception> {
            Err(Exception::IllegalDataValue)
        }
    }
    let mut seen = Vec::new();
    let mut out = Vec::new();
    let o = respond(&mut Refuses, &hex("06 00 05 00 07"), true, &mut out, &mut |r| {
        seen.push(format!("{r:?}"))
    });
    assert_eq!(seen, ["WriteSingle { addr: 5, value: 7 }"]);
    assert_eq!(out, hex("86 03"));
    assert_eq!(o.reason(), Some("illegal_value"));
    out.clear();
    let e = answer(&mut Refuses, &Request::ReadInput { addr: 0, count: 2 }, &mut out).unwrap_err();
    assert_eq!(e, Exception::ServerDeviceFailure);
    assert!(out.is_empty(), "an exception appends nothing");
}
