//! The `rig!` macro on the paper's parallel link: prints `D` and `J` at one state.
//!
//! ```sh
//! cargo run -p hapticgen-macros --example parallel_link
//! ```

hapticgen_macros::rig!(pub mod parallel_link = "../models/parallel_link_2dof.yaml", variant = "horizontal");

fn main() {
    use parallel_link::ParallelLink2dof;

    let rig = ParallelLink2dof::NOMINAL;
    let q = [1.9, 0.2];
    let d = rig.inertia_matrix(&q);
    let j = rig.jacobian(&q);
    println!("parallel link (horizontal) at q = {q:?} rad");
    println!("D = [[{:.6e}, {:.6e}], [{:.6e}, {:.6e}]] kg·m²", d[0][0], d[0][1], d[1][0], d[1][1]);
    println!("J = [[{:.6}, {:.6}], [{:.6}, {:.6}]] m/rad", j[0][0], j[0][1], j[1][0], j[1][1]);
}
