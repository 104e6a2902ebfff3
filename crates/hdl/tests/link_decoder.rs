//! The host's reply decoder re-synchronises on damaged bytes without losing the good
//! frame that follows them, and takes a reply only for the request it answers.

use multistep_hdl::link::{Command, LinkError, Reply, ReplyDecoder, Request, Status, REPLY_SYNC};

fn reply(seq: u8, data: u32) -> Reply {
    Reply {
        seq,
        status: Status::Ok,
        data,
    }
}

#[test]
fn a_stray_sync_byte_costs_one_crc_error_not_the_reply_after_it() {
    let good = reply(7, 0xDEAD_BEEF);
    let mut bytes = vec![REPLY_SYNC];
    bytes.extend_from_slice(&good.encode());
    let out = ReplyDecoder::new().push(&bytes);
    assert!(
        matches!(out.first(), Some(Err(LinkError::Crc { .. }))),
        "{out:?}"
    );
    let ok: Vec<Reply> = out.into_iter().filter_map(Result::ok).collect();
    assert_eq!(
        ok,
        [good],
        "the search restarts one byte on, inside the bad frame"
    );
}

#[test]
fn a_damaged_reply_is_reported_and_the_next_one_still_decodes() {
    let (a, b) = (reply(1, 10), reply(2, 20));
    let mut bytes = a.encode().to_vec();
    bytes[4] ^= 0x01;
    bytes.extend_from_slice(&b.encode());
    let out = ReplyDecoder::new().push(&bytes);
    assert!(matches!(out.first(), Some(Err(_))), "{out:?}");
    let ok: Vec<Reply> = out.into_iter().filter_map(Result::ok).collect();
    assert_eq!(ok, [b]);
}

#[test]
fn a_reply_answers_only_the_request_of_its_sequence_number() {
    let req = Request {
        seq: 4,
        command: Command::Read,
        addr: 0x05,
        data: 0,
    };
    assert_eq!(reply(4, 99).answer(&req).unwrap(), 99);
    // a late reply to the request before: not this one's answer
    assert!(matches!(
        reply(3, 99).answer(&req),
        Err(LinkError::Sequence { got: 3, want: 4 })
    ));
    let refused = Reply {
        status: Status::Busy,
        ..reply(4, 0)
    };
    assert!(matches!(
        refused.answer(&req),
        Err(LinkError::Refused { addr: 0x05, .. })
    ));
}
