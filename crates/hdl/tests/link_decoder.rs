//! The host's reply decoder re-synchronises on damaged bytes without losing the good
//! frame that follows them.

use multistep_hdl::link::{LinkError, Reply, ReplyDecoder, Status, REPLY_SYNC};

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
