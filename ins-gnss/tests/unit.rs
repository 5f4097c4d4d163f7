//! The library's unit tests — tests of private functions, written beside them in
//! `src/` (`mod tests`, compiled with the feature `unit-tests`, which this package's
//! dev-dependency on itself turns on) — run from this binary: the library is then built
//! once for the tests, not a second time as its own unit-test binary (its build was
//! 70 s of the cold test build's compiler time). Each test here is one of `src/`'s, by
//! the same name; its documentation is there.

// ins-gnss/src/config/reference.rs
#[test]
fn every_key_has_a_unit_and_an_example_and_nothing_else_does() {
    ins_gnss::config::reference::tests::every_key_has_a_unit_and_an_example_and_nothing_else_does();
}
#[test]
fn every_example_value_is_accepted_by_the_types() {
    ins_gnss::config::reference::tests::every_example_value_is_accepted_by_the_types();
}
#[test]
fn the_example_file_is_a_valid_configuration_with_every_default() {
    ins_gnss::config::reference::tests::the_example_file_is_a_valid_configuration_with_every_default();
}
#[test]
fn the_shipped_example_and_reference_are_what_the_types_give() {
    ins_gnss::config::reference::tests::the_shipped_example_and_reference_are_what_the_types_give();
}

// ins-gnss/src/run/inputs.rs
#[test]
fn the_start_read_gives_its_answer_on_the_whole_span() {
    ins_gnss::run::unit_tests::inputs::the_start_read_gives_its_answer_on_the_whole_span();
}
#[test]
fn a_recording_replays_the_readers_messages() {
    ins_gnss::run::unit_tests::inputs::a_recording_replays_the_readers_messages();
}

// ins-gnss/src/run/smoothed.rs
#[test]
fn files_are_reversed_in_place() {
    ins_gnss::run::unit_tests::smoothed::files_are_reversed_in_place();
}

// ins-gnss/src/run/fix_errors.rs
#[test]
fn the_bank_is_the_same_one_pass_at_a_time_or_two_replayed_or_read() {
    ins_gnss::run::unit_tests::fix_errors::the_bank_is_the_same_one_pass_at_a_time_or_two_replayed_or_read();
}

// ins-gnss/src/plot/mod.rs
#[test]
fn series_are_cut_at_holes_only() {
    ins_gnss::plot::tests::series_are_cut_at_holes_only();
}
#[test]
fn the_decimator_keeps_a_bounded_even_sample() {
    ins_gnss::plot::tests::the_decimator_keeps_a_bounded_even_sample();
}

// ins-gnss/src/rtk.rs
#[test]
fn fix_timings_and_ratios() {
    ins_gnss::rtk::tests::fix_timings_and_ratios();
}
