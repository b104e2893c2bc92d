!> Test runner: `fpm test [-- FILTER]` runs every test whose "suite/name" contains FILTER.
!! The last line is "N passed, M failed"; the exit code is non-zero on any failure and when
!! FILTER matches no test. The scratch directory of the tests that run commands is made
!! fresh at the start and removed at the end unless a test failed.
program holosym_tests
    use, intrinsic :: iso_fortran_env, only: error_unit
    use holosym_testing, only: run_suite
    use holosym_test_commands, only: reset_scratch, remove_scratch, scratch_path
    use test_quadrature, only: quadrature_tests
    use test_lagrange, only: lagrange_tests
    use test_linalg, only: linalg_tests
    use test_scheme, only: scheme_tests
    use test_errors, only: errors_tests
    use test_integrator, only: integrator_tests
    use test_cli, only: cli_tests
    use test_tables, only: tables_tests
    use test_speed, only: speed_tests
    use test_rattle, only: rattle_tests
    use test_extremes, only: extremes_tests
    use test_bench, only: bench_tests
    use test_extremes_cli, only: extremes_cli_tests
    use test_harness, only: harness_tests
    use test_api, only: api_tests
    use test_reduced, only: reduced_tests
    use test_ensemble, only: ensemble_tests
    use test_models, only: models_tests
    use test_observers, only: observers_tests
    use test_figures, only: figures_tests
    use test_capi, only: capi_tests
    use test_hardening, only: hardening_tests
    use test_cli_hardening, only: cli_hardening_tests
    use test_formula, only: formula_tests
    use test_formula_cli, only: formula_cli_tests
    use test_system_check, only: system_check_tests
    use test_nan_sweep, only: nan_sweep_tests
    use test_refusal, only: refusal_tests
    use test_newton, only: newton_tests
    use test_accuracy, only: accuracy_tests
    use test_events, only: events_tests
    use test_sections, only: sections_tests
    use test_tangent, only: tangent_tests
    use test_lyapunov, only: lyapunov_tests
    use test_iteration, only: iteration_tests
    use test_double_double, only: double_double_tests
    use test_projection, only: projection_tests
    implicit none
    character(len=256) :: filter
    integer :: passed, failed, skipped
    character(len=64) :: summary

    filter = ""
    if (command_argument_count() >= 1) call get_command_argument(1, filter)
    passed = 0
    failed = 0
    skipped = 0
    if (.not. reset_scratch()) then
        write (error_unit, '(a)') "holosym_tests: cannot create " // scratch_path("")
        stop 2, quiet=.true.
    end if
    ! Suites are registered here, one line each.
    call run_suite("harness", harness_tests(), filter, passed, failed, skipped)
    call run_suite("quadrature", quadrature_tests(), filter, passed, failed, skipped)
    call run_suite("lagrange", lagrange_tests(), filter, passed, failed, skipped)
    call run_suite("linalg", linalg_tests(), filter, passed, failed, skipped)
    call run_suite("scheme", scheme_tests(), filter, passed, failed, skipped)
    call run_suite("errors", errors_tests(), filter, passed, failed, skipped)
    call run_suite("integrator", integrator_tests(), filter, passed, failed, skipped)
    call run_suite("api", api_tests(), filter, passed, failed, skipped)
    call run_suite("cli", cli_tests(), filter, passed, failed, skipped)
    call run_suite("tables", tables_tests(), filter, passed, failed, skipped)
    call run_suite("speed", speed_tests(), filter, passed, failed, skipped)
    call run_suite("rattle", rattle_tests(), filter, passed, failed, skipped)
    call run_suite("extremes", extremes_tests(), filter, passed, failed, skipped)
    call run_suite("extremes", extremes_cli_tests(), filter, passed, failed, skipped)
    call run_suite("bench", bench_tests(), filter, passed, failed, skipped)
    call run_suite("reduced", reduced_tests(), filter, passed, failed, skipped)
    call run_suite("ensemble", ensemble_tests(), filter, passed, failed, skipped)
    call run_suite("models", models_tests(), filter, passed, failed, skipped)
    call run_suite("observers", observers_tests(), filter, passed, failed, skipped)
    call run_suite("figures", figures_tests(), filter, passed, failed, skipped)
    call run_suite("capi", capi_tests(), filter, passed, failed, skipped)
    call run_suite("hardening", hardening_tests(), filter, passed, failed, skipped)
    call run_suite("cli_hardening", cli_hardening_tests(), filter, passed, failed, skipped)
    call run_suite("formula", formula_tests(), filter, passed, failed, skipped)
    call run_suite("formula_cli", formula_cli_tests(), filter, passed, failed, skipped)
    call run_suite("checks", system_check_tests(), filter, passed, failed, skipped)
    call run_suite("nan_sweep", nan_sweep_tests(), filter, passed, failed, skipped)
    call run_suite("refusal", refusal_tests(), filter, passed, failed, skipped)
    call run_suite("newton", newton_tests(), filter, passed, failed, skipped)
    call run_suite("accuracy", accuracy_tests(), filter, passed, failed, skipped)
    call run_suite("events", events_tests(), filter, passed, failed, skipped)
    call run_suite("sections", sections_tests(), filter, passed, failed, skipped)
    call run_suite("tangent", tangent_tests(), filter, passed, failed, skipped)
    call run_suite("lyapunov", lyapunov_tests(), filter, passed, failed, skipped)
    call run_suite("iteration", iteration_tests(), filter, passed, failed, skipped)
    call run_suite("double_double", double_double_tests(), filter, passed, failed, skipped)
    call run_suite("projection", projection_tests(), filter, passed, failed, skipped)
    if (passed + failed + skipped == 0) then
        write (error_unit, '(a)') "holosym_tests: no test matches '" // trim(filter) // &
            "' (a test is selected when its suite/name contains the filter, e.g. scheme/)"
        call remove_scratch()
        stop 2, quiet=.true.
    end if
    if (skipped > 0) then
        write (summary, '(i0, " passed, ", i0, " failed, ", i0, " skipped")') passed, failed, &
            skipped
    else
        write (summary, '(i0, " passed, ", i0, " failed")') passed, failed
    end if
    print '(a)', trim(summary)
    if (failed > 0) then
        write (error_unit, '(a)') "holosym_tests: files of the failed tests kept in " // &
            scratch_path("")
        stop 1, quiet=.true.
    end if
    call remove_scratch()
end program holosym_tests
