//! The library's unit tests — tests of private functions, written beside them in
//! `src/` (`mod tests`, compiled with the feature `unit-tests`, which this package's
//! dev-dependency on itself turns on) — run from this binary: the library is then built
//! once for the tests, not a second time as its own unit-test binary (its build was
//! 70 s of the cold test build's compiler time). Each test here is one of `src/`'s, by
//! the same name; its documentation is there.

/// `#[test]` functions, each calling the library's test of its name in `module`.
macro_rules! unit_tests {
    ($($module:path => [$($name:ident),* $(,)?]),* $(,)?) => {
        $($(
            #[test]
            fn $name() {
                use $module as module;
                module::$name();
            }
        )*)*
    };
}

unit_tests! {
    ins_gnss::config::reference::tests => [
        every_key_has_a_unit_and_an_example_and_nothing_else_does,
        every_example_value_is_accepted_by_the_types,
        the_example_file_is_a_valid_configuration_with_every_default,
        the_shipped_example_and_reference_are_what_the_types_give,
    ],
    ins_gnss::run::unit_tests::inputs => [
        the_start_read_gives_its_answer_on_the_whole_span,
        a_recording_replays_the_readers_messages,
    ],
    ins_gnss::run::unit_tests::smoothed => [
        files_are_reversed_in_place,
    ],
    ins_gnss::run::unit_tests::fix_errors => [
        the_bank_is_the_same_one_pass_at_a_time_or_two_replayed_or_read_start_kept,
    ],
    ins_gnss::plot::tests => [
        series_are_cut_at_holes_only,
        the_decimator_keeps_a_bounded_even_sample,
    ],
    ins_gnss::rtk::tests => [
        fix_timings_and_ratios,
    ],
}
