use hapticgen_codegen::model::positions::{PositionIndex, Segment};
fn k(s: &str) -> Segment { Segment::Key(s.into()) }
#[test]
fn probe() {
    let text = "a:\n  b: 1\n  c:\n    d: 2\nlist:\n  - name: q\n    x: 1\n  - {name: r}\n  -\n    name: s\nflow: {e: 1}\nseq:\n- 1\n- [2, 3]\n";
    let idx = PositionIndex::build(text);
    for p in [vec![], vec![k("a")], vec![k("a"), k("c")], vec![k("list"), Segment::Index(0)], vec![k("list"), Segment::Index(1)], vec![k("list"), Segment::Index(2)], vec![k("flow")], vec![k("seq")], vec![k("seq"), Segment::Index(1)], vec![k("list")]] {
        println!("{:?}: value {:?} key {:?}", p, idx.value(&p), idx.key(&p));
    }
}
