//! The firmware's lock-free ring (`firmware/src/ring.rs`), compiled on the
//! host: FIFO order, `N − 1` capacity, wrap-around, and a producer and a
//! consumer on two threads (as the background task and the tick interrupt).

#[allow(dead_code)]
#[path = "../../firmware/src/ring.rs"]
mod ring;

use ring::Ring;

#[test]
fn holds_n_minus_one_in_order_across_wraps() {
    let mut r: Ring<u32, 5> = Ring::new();
    let (mut tx, mut rx) = r.split();
    assert_eq!(tx.capacity(), 4);
    let mut next_in = 0u32;
    let mut next_out = 0u32;
    for round in 0..50 {
        // Fill to capacity: the fifth is refused and given back.
        while tx.ready() {
            tx.enqueue(next_in).unwrap();
            next_in += 1;
        }
        assert_eq!(rx.len(), 4, "round {round}");
        assert_eq!(tx.enqueue(999), Err(999));
        // Drain a varying number, so the indices wrap at every offset.
        for _ in 0..(1 + round % 4) {
            assert_eq!(rx.dequeue(), Some(next_out));
            next_out += 1;
        }
    }
    while let Some(v) = rx.dequeue() {
        assert_eq!(v, next_out);
        next_out += 1;
    }
    assert_eq!(next_out, next_in);
    assert!(rx.is_empty());
    assert_eq!(rx.dequeue(), None);
}

#[test]
fn two_threads_lose_and_reorder_nothing() {
    let r: &'static mut Ring<u64, 17> = Box::leak(Box::new(Ring::new()));
    let (mut tx, mut rx) = r.split();
    const COUNT: u64 = 200_000;
    std::thread::scope(|s| {
        s.spawn(move || {
            let mut i = 0;
            while i < COUNT {
                if tx.enqueue(i).is_ok() {
                    i += 1;
                } else {
                    std::hint::spin_loop();
                }
            }
        });
        s.spawn(move || {
            let mut expect = 0;
            while expect < COUNT {
                if let Some(v) = rx.dequeue() {
                    assert_eq!(v, expect);
                    expect += 1;
                } else {
                    std::hint::spin_loop();
                }
            }
        });
    });
}
