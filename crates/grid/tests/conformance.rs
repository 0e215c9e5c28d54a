//! Every grid kind and phase combination against brute force on the conformance suite.

use std::sync::Arc;
use tb_core::{Accel, Triangle};
use tb_grid::{Initial, IrregularGrid, IrregularParams, UniformGrid, UniformParams};

fn uniform(p: UniformParams) -> impl Fn(&[Triangle]) -> Box<dyn Accel> {
    move |tris| {
        let g = UniformGrid::build(&Arc::from(tris), &p).unwrap();
        g.validate().unwrap();
        Box::new(g)
    }
}

fn irregular(p: IrregularParams) -> impl Fn(&[Triangle]) -> Box<dyn Accel> {
    move |tris| {
        let g = IrregularGrid::build(&Arc::from(tris), &p).unwrap();
        if let Err(e) = g.validate() {
            panic!("{e}");
        }
        Box::new(g)
    }
}

#[test]
fn uniform_grid_conforms() {
    tb_scene::conformance::assert_conforms(&uniform(UniformParams::default()));
}

#[test]
fn macro_regions_conform() {
    let p = UniformParams {
        macro_regions: true,
        ..Default::default()
    };
    tb_scene::conformance::assert_conforms(&uniform(p));
}

#[test]
fn irregular_grid_conforms() {
    tb_scene::conformance::assert_conforms(&irregular(IrregularParams::default()));
}

#[test]
fn irregular_phases_conform() {
    for initial in [Initial::TwoLevel, Initial::Uniform] {
        for (merge, expansion) in [(false, 0), (true, 0), (false, 2), (true, 1)] {
            let p = IrregularParams {
                initial,
                merge,
                expansion,
                lambda_1: if initial == Initial::Uniform {
                    5.0
                } else {
                    0.12
                },
                ..Default::default()
            };
            eprintln!("{p:?}");
            tb_scene::conformance::assert_conforms(&irregular(p));
        }
    }
}
