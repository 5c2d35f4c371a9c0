//! The board's run-time controller (`model_core::BoardController`) as the harness' board:
//! on the channels it runs it gives the demands of the controller built for that model, bit
//! for bit, and a rig with another channel count is an error, not a silent mismatch.

use mil_rig::harness::Board;
use model_core::{
    BoardController, BoardParams, CascadeCoefficients, Controller, ControllerParams, DemandLimits,
    ModelInput, TyreModel, TyreModelParams, TyreParams,
};

const DT: f32 = 5.0e-4;

#[test]
fn the_board_controller_is_the_models_controller_on_its_channels() {
    let limits = DemandLimits {
        min: -1000.0,
        max: 12_000.0,
        rate: 2.0e6,
    };
    let params = BoardParams::tyres(TyreParams::PAPER, 2, limits, 1667.7, 5.0e4);
    let mut board = BoardController::with_params(&params, DT).unwrap();
    let mut tyres = Controller::<TyreModel<2>, 2>::with_params(
        &ControllerParams {
            model: TyreModelParams {
                tyre: [TyreParams::PAPER; 2],
            },
            filter: [CascadeCoefficients::IDENTITY; 2],
            limits: [limits; 2],
            safe_demand: [1667.7; 2],
            safe_ramp_rate: [5.0e4; 2],
        },
        DT,
    )
    .unwrap();
    Board::<2>::start(&mut board).unwrap();
    Board::<2>::start(&mut tyres).unwrap();
    for k in 0..2000 {
        let t = k as f32 * DT;
        let input = ModelInput::<2> {
            position: [0.003 * (9.0 * t).sin(), -0.002 * (5.0 * t).cos()],
            road: [0.004 * (13.0 * t).sin(), 0.001],
            ..ModelInput::default()
        };
        let a = Board::<2>::step(&mut board, &input).unwrap();
        let b = Board::<2>::step(&mut tyres, &input).unwrap();
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "sample {k}");
    }
    assert_eq!(Board::<2>::status(&board), Board::<2>::status(&tyres));
    let e = Board::<4>::step(&mut board, &ModelInput::default()).unwrap_err();
    assert!(e.contains("runs 2 channel(s), the rig has 4"), "{e}");
}
