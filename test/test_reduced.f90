!> Tests of the reduced step (momenta eliminated, banded Newton matrix): it agrees with the
!! general scheme to round-off on every model, its band does not grow with a chain's length,
!! it rejects bad structure declarations, and it keeps the state on failures.
module test_reduced
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, HOLOSYM_NEWTON_NOT_CONVERGED
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_info_t
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_reduced_step, only: reduced_step_t
    use holosym_reduced_scheme, only: reduced_scheme_t, reduced_equations
    use holosym_newton, only: newton_solve, newton_settings_t, newton_report_t, &
        stagnation_floor
    use holosym_kept_newton, only: kept_newton_t, kept_report_t, kept_newton_solve
    use holosym_scheme, only: discrete_scheme
    use holosym_step_scheme, only: step_scheme, scheme_counters_t
    use holosym_test_systems, only: uneven_chain
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: reduced_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Agreement of the two paths after tens of steps: round-off (1e-30 in real128).
    real(wp), parameter :: agreement = max(1.0e-30_wp, 1.0e4_wp * eps)

    !> A chain that declares its mass matrix but not its sparsity: the reduced step's dense
    !! second derivatives (the system's Hessians) instead of differences along colours.
    type, extends(pendulum_chain) :: dense_chain
    contains
        procedure :: constraint_sparsity => dense_chain_sparsity
        procedure :: constraint_jacobian_values => dense_chain_values
        procedure :: potential_sparsity => dense_chain_potential
    end type dense_chain

    !> A pendulum whose declared masses are wrong in sign.
    type, extends(spherical_pendulum) :: negative_mass_pendulum
    contains
        procedure :: diagonal_mass => negative_mass
    end type negative_mass_pendulum

    !> A chain whose declared Phi pattern points outside the matrix.
    type, extends(pendulum_chain) :: bad_pattern_chain
    contains
        procedure :: constraint_sparsity => bad_pattern
    end type bad_pattern_chain

    !> Anharmonic oscillators without constraints (m = 0): H = |p|^2/2 + |q|^2/2 + q_1^4/4.
    type, extends(constrained_hamiltonian) :: free_oscillator
    contains
        procedure :: hamiltonian => oscillator_hamiltonian
        procedure :: dh_dq => oscillator_dh_dq
        procedure :: dh_dp => oscillator_dh_dp
        procedure :: constraint => oscillator_constraint
        procedure :: constraint_jacobian => oscillator_constraint_jacobian
        procedure :: diagonal_mass => oscillator_mass
    end type free_oscillator

    !> A spherical pendulum whose potential gradient turns NaN beyond z = threshold.
    type, extends(spherical_pendulum) :: nan_pendulum
        real(wp) :: threshold = huge(1.0_wp)
    contains
        procedure :: dh_dq => nan_dh_dq
    end type nan_pendulum

contains

    !> The tests of this suite.
    function reduced_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("agrees_with_general_scheme", agrees_with_general), &
            new_test("no_constraints", no_constraints), &
            new_test("general_fallback_setting_honoured", fallback_setting), &
            new_test("loose_tolerance_real64_iterations_only", loose_tolerance), &
            new_test("unreachable_tolerance_stops_at_round_off", unreachable_tolerance), &
            new_test("dense_output_and_multipliers_agree", dense_output_agrees), &
            new_test("sparse_and_dense_derivatives_agree", sparse_equals_dense), &
            new_test("band_independent_of_chain_length", band_independent), &
            new_test("rejects_bad_declarations", bad_declarations), &
            new_test("failure_keeps_state", failure_keeps_state), &
            new_test("nearly_dependent_constraints_fall_back", nearly_dependent), &
            new_test("options_it_does_not_honour_refused", options_refused), &
            new_test("newton_settings_act_on_it", newton_settings_act), &
            new_test("newton_solve_solves_the_reduced_scheme", newton_solve_reduced), &
            new_test("kept_newton_solve_solves_the_general_scheme", kept_newton_general), &
            new_test("one_interface_for_both_schemes", one_interface) &
        ]
    end function reduced_tests

    !> Run `steps` steps with the reduced step and with the general scheme from (q0, p0).
    subroutine both_paths(error, sys, q0, p0, mm, nn, gg, h, steps, label)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: mm, nn, gg, steps
        character(len=*), intent(in) :: label
        type(constrained_integrator) :: reduced, general
        type(holosym_status_t) :: status
        real(wp) :: qr(size(q0)), pr(size(q0)), qg(size(q0)), pg(size(q0)), scale
        general%structured = .false.
        call reduced%init(sys, mm, nn, gg, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, label // ": init")
        call general%init(sys, mm, nn, gg, status)
        if (allocated(error)) return
        qr = q0
        pr = p0
        qg = q0
        pg = p0
        call reduced%integrate(sys, qr, pr, h, steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, label // ": reduced")
        call general%integrate(sys, qg, pg, h, steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, label // ": general")
        if (allocated(error)) return
        scale = max(1.0_wp, maxval(abs(qg)), maxval(abs(pg)))
        call check(error, maxval(abs(qr - qg)) <= agreement * scale .and. &
            maxval(abs(pr - pg)) <= agreement * scale, label // ": paths differ by " // &
            real_str(max(maxval(abs(qr - qg)), maxval(abs(pr - pg)))))
        call check(error, reduced%stats%steps == steps .and. &
            reduced%stats%residual_evaluations > 0, label // ": reduced step counted")
    end subroutine both_paths

    subroutine agrees_with_general(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        type(pendulum_chain) :: chain
        real(wp) :: q3(3), p3(3), q6(6), p6(6), q2(2), p2(2), q8(8), p8(8)
        sphere = spherical_pendulum()
        call sphere%initial_state(q3, p3)
        call both_paths(error, sphere, q3, p3, 2, 1, 3, 0.125_wp, 24, "sphere (2,1,3)")
        call both_paths(error, sphere, q3, p3, 4, 3, 5, 0.25_wp, 12, "sphere (4,3,5)")
        call both_paths(error, sphere, q3, p3, 1, 0, 2, 0.125_wp, 24, "sphere (1,0,2)")
        linkage = spring_linkage()
        call linkage%initial_state(q6, p6)
        call both_paths(error, linkage, q6, p6, 3, 2, 4, 0.25_wp, 12, "linkage (3,2,4)")
        planar = planar_pendulum()
        call planar%initial_state(q2, p2)
        call both_paths(error, planar, q2, p2, 8, 7, 9, 0.125_wp, 12, "planar (8,7,9)")
        call uneven_chain(chain, q8, p8)
        call both_paths(error, chain, q8, p8, 4, 3, 5, 0.01_wp, 20, "chain of 4 (4,3,5)")
        call both_paths(error, chain, q8, p8, 2, 1, 3, 0.05_wp, 20, "chain of 4 (2,1,3)")
    end subroutine agrees_with_general

    !> Systems without constraints (m = 0), of one and two coordinates.
    subroutine no_constraints(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(free_oscillator) :: sys
        real(wp), parameter :: q0(2) = [1.0_wp, 0.5_wp], p0(2) = [0.0_wp, 0.3_wp]
        integer :: n
        do n = 1, 2
            sys%n = n
            sys%m = 0
            call both_paths(error, sys, q0(1:n), p0(1:n), 3, 2, 4, 0.1_wp, 30, &
                            "oscillator n = " // int_str(n))
        end do
    end subroutine no_constraints

    !> A Newton tolerance the real64 iterations meet (1e-12) needs no working-precision
    !! residual, and the states stay within that tolerance of full-accuracy ones.
    subroutine loose_tolerance(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: loose, full
        type(holosym_status_t) :: status
        real(wp) :: ql(3), pl(3), qf(3), pf(3)
        sys = spherical_pendulum()
        call sys%initial_state(ql, pl)
        qf = ql
        pf = pl
        loose%newton%tolerance = 1.0e-12_wp
        call loose%init(sys, 4, 3, 5, status)
        call full%init(sys, 4, 3, 5, status)
        call loose%integrate(sys, ql, pl, 0.25_wp, 20, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "loose run")
        call full%integrate(sys, qf, pf, 0.25_wp, 20, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "full run")
        if (allocated(error)) return
        call check(error, max(maxval(abs(ql - qf)), maxval(abs(pl - pf))) <= 1.0e-11_wp, &
            "loose and full runs differ by " // &
            real_str(max(maxval(abs(ql - qf)), maxval(abs(pl - pf)))))
        if (precision(1.0_wp) > precision(1.0_dp)) then
            call check(error, loose%stats%residual_evaluations == 0 .and. &
                loose%stats%lowered_residual_evaluations > 0, "working-precision " // &
                "residuals with tolerance 1e-12: " // &
                int_str(int(loose%stats%residual_evaluations)))
            call check(error, full%stats%residual_evaluations >= 20, "full accuracy uses " // &
                "working-precision residuals")
        end if
    end subroutine loose_tolerance

    !> A Newton tolerance below round-off (epsilon / 1000) cannot be met: the iterations
    !! stop when the corrections stagnate at round-off (the default stagnation level), on
    !! both paths, well before the iteration limit.
    subroutine unreachable_tolerance(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(16), p(16), theta(8)
        integer :: path
        sys = pendulum_chain(8)
        theta = 0.5_wp
        do path = 1, 2
            call sys%state_from_angles(theta, 0 * theta, q, p)
            integ%structured = path == 1
            integ%newton%tolerance = epsilon(1.0_wp) / 1000
            call integ%init(sys, 2, 1, 3, status)
            call integ%integrate(sys, q, p, 0.01_wp, 8, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "path " // &
                int_str(path))
            call check(error, integ%stats%newton_iterations < 8 * 20, "path " // &
                int_str(path) // ": " // int_str(int(integ%stats%newton_iterations)) // &
                " Newton iterations for 8 steps")
        end do
    end subroutine unreachable_tolerance

    !> Dense output (q~, p~, lambda~ inside the last step) and the multipliers at the nodes
    !! are the same polynomials on both paths.
    subroutine dense_output_agrees(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(constrained_integrator) :: reduced, general
        type(step_info_t) :: info_r, info_g
        type(holosym_status_t) :: status
        real(wp) :: qr(6), pr(6), qg(6), pg(6), dq(6, 2), dp(6, 2), dl(3, 2)
        integer :: k
        sys = spring_linkage()
        call sys%initial_state(qr, pr)
        qg = qr
        pg = pr
        general%structured = .false.
        call reduced%init(sys, 4, 3, 5, status)
        call general%init(sys, 4, 3, 5, status)
        do k = 1, 3
            call reduced%step(sys, qr, pr, 0.25_wp, info_r, status)
            call general%step(sys, qg, pg, 0.25_wp, info_g, status)
        end do
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "steps")
        if (allocated(error)) return
        call reduced%dense_output(0.3_wp, dq(:, 1), dp(:, 1), dl(:, 1), status)
        call general%dense_output(0.3_wp, dq(:, 2), dp(:, 2), dl(:, 2), status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "dense output")
        call check(error, maxval(abs(dq(:, 1) - dq(:, 2))) <= agreement .and. &
            maxval(abs(dp(:, 1) - dp(:, 2))) <= agreement .and. &
            maxval(abs(dl(:, 1) - dl(:, 2))) <= agreement * 100, &
            "dense output differs: q " // real_str(maxval(abs(dq(:, 1) - dq(:, 2)))) // &
            ", p " // real_str(maxval(abs(dp(:, 1) - dp(:, 2)))) // ", lambda " // &
            real_str(maxval(abs(dl(:, 1) - dl(:, 2)))))
        call check(error, maxval(abs(info_r%lambda - info_g%lambda)) <= agreement * 100, &
            "multipliers at the nodes differ by " // &
            real_str(maxval(abs(info_r%lambda - info_g%lambda))))
        call check(error, info_r%constraint_residual <= agreement .and. &
            info_r%velocity_residual <= agreement, "step diagnostics at round-off")
    end subroutine dense_output_agrees

    !> The chain with its sparsity declared (differences along colours: 8 links are past
    !! the size up to which the dense second derivatives are taken anyway) and without
    !! (the system's dense Hessians) gives the same states.
    subroutine sparse_equals_dense(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: sparse
        type(dense_chain) :: dense
        type(constrained_integrator) :: a, b
        type(holosym_status_t) :: status
        real(wp) :: qa(16), pa(16), qb(16), pb(16)
        integer :: k
        sparse = pendulum_chain(8, masses=[1.0_wp, 2.0_wp])
        dense%pendulum_chain = sparse
        call sparse%state_from_angles([(0.2_wp * k, k = 1, 8)], [(0.1_wp * (k - 1), &
                                      k = 1, 8)], qa, pa)
        qb = qa
        pb = pa
        call a%init(sparse, 3, 2, 4, status)
        call b%init(dense, 3, 2, 4, status)
        call a%integrate(sparse, qa, pa, 0.02_wp, 15, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "sparse")
        call b%integrate(dense, qb, pb, 0.02_wp, 15, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "dense")
        if (allocated(error)) return
        call check(error, maxval(abs(qa - qb)) <= agreement .and. &
            maxval(abs(pa - pb)) <= agreement, "sparse and dense differ by " // &
            real_str(max(maxval(abs(qa - qb)), maxval(abs(pa - pb)))))
    end subroutine sparse_equals_dense

    !> The chain's Newton matrix has the same band for 8, 32 and 128 links, and is stored
    !! banded (memory linear in the length).
    subroutine band_independent(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(reduced_step_t) :: step
        type(holosym_status_t) :: status
        integer :: k, links(3) = [8, 32, 128], kl(3), ku(3)
        do k = 1, 3
            call step%init(pendulum_chain(links(k)), 4, 3, 5, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
            if (allocated(error)) return
            kl(k) = step%newton%factors%kl
            ku(k) = step%newton%factors%ku
            call check(error, step%scheme%nx == 13 * links(k), "unknowns 13 per link")
            if (links(k) >= 32) call check(error, step%newton%factors%banded .and. &
                size(step%newton%factors%a) == (2 * kl(k) + ku(k) + 1) * step%scheme%nx, &
                "banded storage for " // int_str(links(k)) // " links")
        end do
        call check(error, all(kl == kl(1)) .and. all(ku == ku(1)) .and. kl(1) < 52, &
            "band grows with the chain: kl = " // int_str(kl(1)) // ", " // int_str(kl(3)))
    end subroutine band_independent

    subroutine bad_declarations(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(negative_mass_pendulum) :: negative
        type(bad_pattern_chain) :: bad
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        negative%spherical_pendulum = spherical_pendulum()
        call integ%init(negative, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "negative mass")
        call check(error, index(status%message, "mass") > 0, "message: " // status%message)
        bad%pendulum_chain = pendulum_chain(3)
        call integ%init(bad, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "bad pattern")
        call check(error, index(status%message, "constraint_sparsity") > 0, &
            "message: " // status%message)
        ! The general scheme does not need the declarations.
        integ%structured = .false.
        call integ%init(negative, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "general path")
    end subroutine bad_declarations

    !> Each option the reduced step does not honour is refused at the first step with
    !! HOLOSYM_INVALID_ARGUMENT naming it (the state unchanged), and honoured by the general
    !! step (`structured = .false.`); 'user' Hessians are refused where the reduced step
    !! differences the gradients (a declared sparsity), 'differences' where it calls the
    !! system's Hessians (none declared), and the other choice of each is accepted.
    subroutine options_refused(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(6) = [character(len=32) :: &
            "newton%simplified", "newton%presolve", "linear_solver", "jacobian", &
            "linear_increments", "linear_solver"]
        type(pendulum_chain) :: sparse
        type(dense_chain) :: dense
        integer :: k
        ! Eight links: large enough for the reduced step to use the declared sparsity.
        sparse = pendulum_chain(8)
        dense%pendulum_chain = pendulum_chain(8)
        do k = 1, size(names)
            if (k == 2 .and. precision(1.0_wp) <= precision(1.0_dp)) cycle
            call expect(sparse, k, "", .true., trim(names(k)))
            call expect(sparse, k, "", .false., "")
        end do
        call expect(sparse, 0, "user", .true., "hessians = 'user'")
        call expect(sparse, 0, "differences", .true., "")
        call expect(sparse, 0, "user", .false., "")
        call expect(dense, 0, "differences", .true., "hessians = 'differences'")
        call expect(dense, 0, "user", .true., "")
        call expect(dense, 0, "automatic", .true., "")
        call expect(dense, 0, "differences", .false., "")
    contains
        !> One step with option `option` (1..6 as `names`, 0 none) and `hessians` ("" the
        !! default) on path `structured`: refused naming `refusal`, or a success when "".
        subroutine expect(sys, option, hessians, structured, refusal)
            class(pendulum_chain), intent(in) :: sys
            integer, intent(in) :: option
            character(len=*), intent(in) :: hessians, refusal
            logical, intent(in) :: structured
            type(constrained_integrator) :: integ
            type(holosym_status_t) :: status
            type(step_info_t) :: info
            real(wp) :: q(16), p(16), q0(16), p0(16), theta(8)
            character(len=:), allocatable :: label
            theta = 0.4_wp
            call sys%state_from_angles(theta, 0 * theta, q0, p0)
            q = q0
            p = p0
            integ%structured = structured
            select case (option)
            case (1)
                integ%newton%simplified = .false.
            case (2)
                integ%newton%presolve = .false.
            case (3)
                integ%linear_solver = "real128"
            case (4)
                integ%jacobian = "residual-differences"
            case (5)
                integ%linear_increments = .false.
            case (6)
                integ%linear_solver = "native"
            end select
            if (len(hessians) > 0) integ%hessians = hessians
            label = "option " // int_str(option) // " hessians '" // hessians // &
                "' structured " // merge("T", "F", structured)
            call integ%init(sys, 2, 1, 3, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, label // ": init")
            if (allocated(error)) return
            call integ%step(sys, q, p, 0.01_wp, info, status)
            if (len(refusal) == 0) then
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, label)
                return
            end if
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, label)
            if (allocated(error)) return
            call check(error, index(status%message, refusal) > 0 .and. &
                index(status%message, "structured = .false.") > 0, label // &
                ": message '" // status%message // "'")
            call check(error, all(q == q0) .and. all(p == p0), label // ": state changed")
        end subroutine expect
    end subroutine options_refused

    !> The Newton settings act on the reduced step: one iteration allowed cannot converge
    !! (HOLOSYM_NEWTON_NOT_CONVERGED), a contraction limit near 0 renews the factors more
    !! often than the default, and the defaults (0 and a negative cost: the step's own
    !! values) give the same run as those values set explicitly.
    subroutine newton_settings_act(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: sys
        type(constrained_integrator) :: integ, runs(3)
        type(holosym_status_t) :: status
        real(wp) :: q(16), p(16), q_default(16), p_default(16), q0(16), p0(16), theta(8)
        integer :: trial
        integer(kind=8) :: factorizations(3)
        sys = pendulum_chain(8)
        theta = 0.6_wp
        call sys%state_from_angles(theta, 0 * theta, q0, p0)
        q = q0
        p = p0
        integ%newton%max_iterations = 1
        call integ%init(sys, 4, 3, 5, status)
        call integ%integrate(sys, q, p, 0.05_wp, 4, status=status)
        call check_status_code(error, status%code, HOLOSYM_NEWTON_NOT_CONVERGED, &
            "max_iterations = 1")
        call check(error, all(q == q0) .and. all(p == p0), "state changed by a failure")
        if (allocated(error)) return
        do trial = 1, 3
            q = q0
            p = p0
            select case (trial)
            case (2)
                runs(trial)%newton%contraction_limit = 1.0e-30_wp
            case (3)
                runs(trial)%newton%contraction_limit = 0.1_wp
                runs(trial)%newton%jacobian_cost = 1
            end select
            call runs(trial)%init(sys, 4, 3, 5, status)
            call runs(trial)%integrate(sys, q, p, 0.05_wp, 20, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "trial " // &
                int_str(trial))
            if (allocated(error)) return
            factorizations(trial) = runs(trial)%stats%lu_factorizations
            if (trial == 1) then
                q_default = q
                p_default = p
            else if (trial == 3) then
                call check(error, all(q == q_default) .and. all(p == p_default), &
                    "the reduced step's own values set explicitly change the run")
            end if
        end do
        call check(error, factorizations(2) > factorizations(1), "contraction_limit " // &
            "1e-30: " // int_str(int(factorizations(2))) // " factorizations, default " // &
            int_str(int(factorizations(1))))
        call check(error, factorizations(3) == factorizations(1), "own values: " // &
            int_str(int(factorizations(3))) // " factorizations, default " // &
            int_str(int(factorizations(1))))
    end subroutine newton_settings_act

    !> The reduced scheme implements Newton's interface (`nonlinear_system`, through
    !! `reduced_equations`): `newton_solve`
    !! (full Newton, working-precision LU of its Newton matrix) solves one step of it to
    !! the state the integrator's reduced step reaches, within round-off, on the spherical
    !! pendulum (dense second derivatives) and a chain of 8 links (banded, coloured
    !! differences); with and without the real64 pre-solve (`residual_lowered`).
    subroutine newton_solve_reduced(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: pendulum
        type(pendulum_chain) :: chain
        real(wp) :: theta(8)
        integer :: mode
        pendulum = spherical_pendulum()
        chain = pendulum_chain(8)
        do mode = 1, 2
            call compare(pendulum, mode == 2)
            call compare(chain, mode == 2)
            if (allocated(error)) return
        end do
    contains
        subroutine compare(sys, presolve)
            class(constrained_hamiltonian), intent(in), target :: sys
            logical, intent(in) :: presolve
            type(reduced_scheme_t), target :: scheme
            type(reduced_equations) :: equations
            type(constrained_integrator) :: integ
            type(newton_settings_t) :: settings
            type(newton_report_t) :: report
            type(holosym_status_t) :: status
            type(step_info_t) :: info
            real(wp), allocatable :: q(:), p(:), q1(:), p1(:), x(:), f(:), dq(:), dpb(:)
            real(wp) :: h, difference
            allocate (q(sys%n), p(sys%n), dq(sys%n), dpb(sys%n))
            select type (sys)
            type is (pendulum_chain)
                theta = 0.5_wp
                call sys%state_from_angles(theta, 0 * theta, q, p)
                h = 0.01_wp
            type is (spherical_pendulum)
                call sys%initial_state(q, p)
                h = 0.125_wp
            end select
            q1 = q
            p1 = p
            call integ%init(sys, 4, 3, 5, status)
            call integ%step(sys, q1, p1, h, info, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "integrator step")
            call scheme%init(sys, 4, 3, 5, status)
            call scheme%set_step(sys, q, p, h, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "scheme set-up")
            if (allocated(error)) return
            allocate (x(scheme%nx), f(scheme%nx))
            x = 0
            settings%presolve = presolve
            equations%scheme => scheme
            call newton_solve(equations, x, settings, max(maxval(abs(q)), maxval(abs(p))), &
                              report, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "newton_solve: " // &
                status%message)
            if (allocated(error)) return
            ! The step's results from an evaluation at the solution.
            call scheme%residual(x, f, status)
            call scheme%increments(dq, dpb, .false.)
            difference = max(maxval(abs(q + dq - q1)), maxval(abs(p + dpb - p1)))
            call check(error, difference <= agreement, "newton_solve on the reduced " // &
                "scheme and the reduced step differ by " // real_str(difference) // &
                " (n = " // int_str(sys%n) // ", presolve " // merge("T", "F", presolve) // &
                ", " // int_str(report%iterations) // " iterations)")
        end subroutine compare
    end subroutine newton_solve_reduced

    !> The general scheme through the reduced step's iteration: `kept_newton_solve` (real64
    !! factors of the dense Newton matrix `jacobian_lowered`, kept across the steps) solves
    !! ten steps of the spherical pendulum and the spring-linkage with (M, N, G) =
    !! (4, 3, 5), h = 1/8, to the states of `newton_solve` on the same scheme within
    !! round-off, keeping its factors across iterations (fewer Newton matrices than
    !! iterations).
    subroutine kept_newton_general(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: pendulum
        type(spring_linkage), target :: linkage
        pendulum = spherical_pendulum()
        linkage = spring_linkage()
        call compare(pendulum)
        if (allocated(error)) return
        call compare(linkage)
    contains
        subroutine compare(sys)
            class(constrained_hamiltonian), intent(in), target :: sys
            type(discrete_scheme) :: scheme
            type(kept_newton_t) :: state
            type(kept_report_t) :: work
            type(newton_settings_t) :: settings
            type(newton_report_t) :: report
            type(holosym_status_t) :: status
            real(wp), allocatable :: q(:, :), p(:, :), x(:), y(:), dq(:), dp(:)
            real(wp) :: h, scale, difference
            integer :: k, path
            h = 0.125_wp
            allocate (q(sys%n, 2), p(sys%n, 2), dq(sys%n), dp(sys%n))
            select type (sys)
            type is (spherical_pendulum)
                call sys%initial_state(q(:, 1), p(:, 1))
            type is (spring_linkage)
                call sys%initial_state(q(:, 1), p(:, 1))
            end select
            q(:, 2) = q(:, 1)
            p(:, 2) = p(:, 1)
            call scheme%init(4, 3, 5, sys%n, sys%m, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "scheme set-up")
            if (allocated(error)) return
            allocate (x(scheme%nx), y(scheme%nx))
            call state%setup(scheme%nx, scheme%nx - 1, scheme%nx - 1)
            do k = 1, 10
                do path = 1, 2
                    call scheme%set_step(sys, q(:, path), p(:, path), h)
                    call scheme%constant_guess(x)
                    scale = max(maxval(abs(q(:, path))), maxval(abs(p(:, path))))
                    if (path == 1) then
                        call newton_solve(scheme, x, settings, scale, report, status)
                    else
                        call kept_newton_solve(scheme, x, state, settings, scale, &
                                               stagnation_floor(settings), work, status)
                    end if
                    call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step " // &
                        int_str(k) // ", solver " // int_str(path) // ": " // status%message)
                    if (allocated(error)) return
                    call scheme%increments(x, dq, dp, status)
                    q(:, path) = q(:, path) + dq
                    p(:, path) = p(:, path) + dp
                end do
            end do
            difference = max(maxval(abs(q(:, 1) - q(:, 2))), maxval(abs(p(:, 1) - p(:, 2))))
            call check(error, difference <= agreement, "kept_newton_solve and " // &
                "newton_solve differ by " // real_str(difference) // " after 10 steps " // &
                "(n = " // int_str(sys%n) // ")")
            call check(error, work%factorizations < work%iterations, &
                int_str(work%factorizations) // " Newton matrices for " // &
                int_str(work%iterations) // " iterations (n = " // int_str(sys%n) // ")")
        end subroutine compare
    end subroutine kept_newton_general

    !> Both schemes through the one interface (`step_scheme`), by the same code: bound to
    !! the first step of the spherical pendulum (h = 1/8) and of a chain of 8 (h = 0.01)
    !! with (M, N, G) = (4, 3, 5) and solved by `newton_solve` from the constant guess,
    !! their increments, displacement nodes and dense output at tau = 0.3 and 1 agree to
    !! round-off, their multipliers to round-off over h^2; the dense q at tau = 1 is q_b, the dense p there is p_b within
    !! the momentum jump (the local error: p~ has degree N), which is small; each counts
    !! its residuals.
    subroutine one_interface(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: pendulum
        type(pendulum_chain), target :: chain
        real(wp) :: theta(8), q(3), p(3), qc(16), pc(16)
        pendulum = spherical_pendulum()
        call pendulum%initial_state(q, p)
        call both_schemes_agree(pendulum, q, p, 0.125_wp, error)
        if (allocated(error)) return
        chain = pendulum_chain(8)
        theta = 0.5_wp
        call chain%state_from_angles(theta, 0 * theta, qc, pc)
        call both_schemes_agree(chain, qc, pc, 0.01_wp, error)
    end subroutine one_interface

    !> `one_interface` for one system and start state.
    subroutine both_schemes_agree(sys, q, p, h, error)
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(test_error_t), allocatable, intent(inout) :: error
        type(discrete_scheme) :: general
        type(reduced_scheme_t), target :: reduced
        type(reduced_equations) :: equations
        type(holosym_status_t) :: status
        real(wp) :: dq(sys%n, 2), dp(sys%n, 2), nodes(sys%n, 0:4, 2), jump(2)
        real(wp) :: lambda(sys%m, 0:4, 2), qd(sys%n, 2, 2), pd(sys%n, 2, 2)
        real(wp) :: ld(sys%m, 2, 2), residuals(2), difference
        integer :: k
        call general%init(4, 3, 5, sys%n, sys%m, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "general set-up")
        if (allocated(error)) return
        call reduced%init(sys, 4, 3, 5, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "reduced set-up")
        if (allocated(error)) return
        equations%scheme => reduced
        call through_interface(general, 1)
        if (allocated(error)) return
        call through_interface(equations, 2)
        if (allocated(error)) return
        difference = max(maxval(abs(dq(:, 1) - dq(:, 2))), maxval(abs(dp(:, 1) - dp(:, 2))), &
            maxval(abs(nodes(:, :, 1) - nodes(:, :, 2))), &
            maxval(abs(qd(:, :, 1) - qd(:, :, 2))), maxval(abs(pd(:, :, 1) - pd(:, :, 2))))
        call check(error, difference <= agreement, "the two schemes' steps differ by " // &
            real_str(difference) // " (n = " // int_str(sys%n) // ")")
        ! The multipliers are fixed by the solve less tightly than the state: the unknowns
        ! are h lambda (reduced) and lambda enters the positions through h^2.
        difference = max(maxval(abs(lambda(:, :, 1) - lambda(:, :, 2))), &
                         maxval(abs(ld(:, :, 1) - ld(:, :, 2)))) / max(1.0_wp, maxval(abs(lambda)))
        call check(error, difference <= agreement / h**2, "their multipliers differ by " // &
            real_str(difference) // " (relative; max |lambda| " // &
            real_str(maxval(abs(lambda))) // ", n = " // int_str(sys%n) // ")")
        do k = 1, 2
            difference = maxval(abs(qd(:, 2, k) - q - dq(:, k)))
            call check(error, difference <= agreement, "scheme " // int_str(k) // &
                ": dense q at tau = 1 is " // real_str(difference) // " from q_b")
            difference = maxval(abs(pd(:, 2, k) - p - dp(:, k)))
            call check(error, difference <= jump(k) * (1 + 1.0e-20_wp) + agreement, &
                "scheme " // int_str(k) // ": dense p at tau = 1 is " // &
                real_str(difference) // " from p_b, beyond the momentum jump " // &
                real_str(jump(k)))
            call check(error, residuals(k) > 0 .and. jump(k) < 1.0e-6_wp, "scheme " // &
                int_str(k) // ": " // real_str(residuals(k)) // " residuals counted, " // &
                "momentum jump " // real_str(jump(k)))
        end do
    contains
        !> The step through the interface alone, into column k of the host's arrays.
        subroutine through_interface(scheme, k)
            class(step_scheme), intent(inout) :: scheme
            integer, intent(in) :: k
            type(newton_settings_t) :: settings
            type(newton_report_t) :: report
            real(wp), allocatable :: x(:)
            type(scheme_counters_t) :: before, after
            real(wp) :: lambda_tau(sys%m)
            integer :: i
            before = scheme%work()
            call scheme%bind(sys, q, p, h, status)
            if (status%ok()) then
                allocate (x(scheme%unknowns()))
                call scheme%constant_guess(x)
                call newton_solve(scheme, x, settings, max(maxval(abs(q)), maxval(abs(p))), &
                                  report, status)
            end if
            if (status%ok()) call scheme%increments(x, dq(:, k), dp(:, k), status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "scheme " // &
                int_str(k) // ": " // status%message)
            if (allocated(error)) return
            do i = 0, 4
                call scheme%solution_node(x, i, nodes(:, i, k))
            end do
            call scheme%node_values(x, lambda(:, :, k))
            jump(k) = scheme%momentum_jump(x, dp(:, k))
            call scheme%dense(x, q, p, h, 0.3_wp, qd(:, 1, k), pd(:, 1, k), lambda_tau)
            ld(:, 1, k) = lambda_tau
            call scheme%dense(x, q, p, h, 1.0_wp, qd(:, 2, k), pd(:, 2, k), lambda_tau)
            ld(:, 2, k) = lambda_tau
            after = scheme%work()
            residuals(k) = real(after%residuals - before%residuals, wp)
        end subroutine through_interface
    end subroutine both_schemes_agree

    !> A NaN gradient in the third step: code 4, the state of step 2 kept.
    subroutine failure_keeps_state(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(nan_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q2(3), p2(3)
        integer :: done
        sys%spherical_pendulum = spherical_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 2, 1, 3, status)
        call integ%integrate(sys, q, p, 0.125_wp, 2, status=status)
        q2 = q
        p2 = p
        call integ%integrate(sys, q, p, 0.125_wp, 1, status=status)
        ! z grows: a threshold between z after step 2 and step 3.
        sys%threshold = (q2(3) + q(3)) / 2
        call sys%initial_state(q, p)
        call integ%integrate(sys, q, p, 0.125_wp, 5, steps_done=done, status=status)
        call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, "NaN gradient")
        call check(error, done == 2, "steps done " // int_str(done))
        call check(error, all(q == q2) .and. all(p == p2), "state of step 2 kept")
    end subroutine failure_keeps_state

    !> A rod only 1e-8 longer than the tracks' distance (nearly dependent constraints): the
    !! real64 factors of the reduced step fail and the general scheme's working-precision
    !! ones take over.
    subroutine nearly_dependent(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(6), p(6), radius, excess, delta
        delta = max(1.0e-8_wp, eps**0.25_wp)
        sys = spring_linkage()
        radius = sys%track_radius
        sys%rod_length = 2 * radius * (1 + delta)
        excess = 2 * radius * sqrt(delta * (2 + delta))
        q = [-excess / 2, -radius, excess / 2, radius, -excess / 2, excess / 2]
        p = 0
        call integ%init(sys, 2, 1, 3, status)
        call integ%integrate(sys, q, p, 1.0_wp / 64, 2, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "nearly dependent")
    end subroutine nearly_dependent

    ! ------------------------------------------------------------------ test systems

    subroutine dense_chain_sparsity(self, rows, columns)
        class(dense_chain), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        integer :: l, i
        allocate (rows(self%m * self%n), columns(self%m * self%n))
        do i = 1, self%n
            do l = 1, self%m
                rows(l + (i - 1) * self%m) = l
                columns(l + (i - 1) * self%m) = i
            end do
        end do
    end subroutine dense_chain_sparsity

    subroutine dense_chain_values(self, q, rows, columns, values)
        class(dense_chain), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        real(wp) :: jacobian(self%m, self%n)
        integer :: e
        call self%constraint_jacobian(q, jacobian)
        do e = 1, size(rows)
            values(e) = jacobian(rows(e), columns(e))
        end do
    end subroutine dense_chain_values

    subroutine dense_chain_potential(self, rows, columns)
        class(dense_chain), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        integer :: i, k
        allocate (rows(self%n**2), columns(self%n**2))
        do k = 1, self%n
            do i = 1, self%n
                rows(i + (k - 1) * self%n) = i
                columns(i + (k - 1) * self%n) = k
            end do
        end do
    end subroutine dense_chain_potential

    logical function negative_mass(self, mass) result(declared)
        class(negative_mass_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = -1
        declared = .true.
    end function negative_mass

    subroutine bad_pattern(self, rows, columns)
        class(bad_pattern_chain), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1, 2, 3]
        columns = [1, 3, self%n + 1]
    end subroutine bad_pattern

    function oscillator_hamiltonian(self, q, p) result(energy)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p**2) / 2 + sum(q**2) / 2 + q(1)**4 / 4
    end function oscillator_hamiltonian

    subroutine oscillator_dh_dq(self, q, p, gradient)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = q
        gradient(1) = gradient(1) + q(1)**3
    end subroutine oscillator_dh_dq

    subroutine oscillator_dh_dp(self, q, p, gradient)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = p
    end subroutine oscillator_dh_dp

    subroutine oscillator_constraint(self, q, phi)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi = 0
    end subroutine oscillator_constraint

    subroutine oscillator_constraint_jacobian(self, q, jacobian)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian = 0
    end subroutine oscillator_constraint_jacobian

    logical function oscillator_mass(self, mass) result(declared)
        class(free_oscillator), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = 1
        declared = .true.
    end function oscillator_mass

    subroutine nan_dh_dq(self, q, p, gradient)
        use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
        class(nan_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        call self%spherical_pendulum%dh_dq(q, p, gradient)
        if (q(3) > self%threshold) gradient(3) = ieee_value(1.0_wp, ieee_quiet_nan)
    end subroutine nan_dh_dq

    !> A reduced step that fails (a step of h = 50, far beyond what the spherical pendulum
    !! resolves) is solved again by the general step when `general_fallback` is set (its
    !! message then names the reduced failure it follows), and fails at once when not;
    !! either way the state is unchanged.
    subroutine fallback_setting(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integs(2) ! one fresh integrator per setting
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3)
        logical :: fallback
        integer :: k
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        do k = 1, 2
            fallback = k == 1
            integs(k)%general_fallback = fallback
            call integs(k)%init(sys, 4, 3, 5, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init: " // &
                status%message)
            if (allocated(error)) return
            q = q0
            p = p0
            call integs(k)%step(sys, q, p, 50.0_wp, status=status)
            call check(error, .not. status%ok(), "h = 50 fails (fallback " // &
                merge("on) ", "off)", fallback))
            call check(error, (index(status%message, "(after the ") > 0) .eqv. fallback, &
                "the general step tried only with the fallback set: " // status%message)
            call check(error, all(q == q0) .and. all(p == p0), "state unchanged")
            if (allocated(error)) return
        end do
    end subroutine fallback_setting

end module test_reduced
