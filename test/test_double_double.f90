!> Tests of the double-double inner sums of the reduced step's working-precision residual
!! (`residual_sums`, holosym_reduced_kernels_dd): the kernels against the working-precision
!! ones to their rounding, runs that agree with working-precision sums to the Newton
!! tolerance on built-in systems and a model file, the automatic choice, and the refusals.
module test_double_double
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_formula_model, only: formula_model, load_model
    use holosym_reduced_kernels_wp, only: reduced_tables, reduced_evaluation, &
        allocate_evaluation, gauss_positions, node_sums
    use holosym_reduced_kernels_dd, only: dd_tables_t, dd_tables_init, dd_step_tables, &
        dd_gauss_positions, dd_node_sums, double_double_floor
    use holosym_test_systems, only: builtin_system
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, &
        check_status_code, skip
    use holosym_test_commands, only: command_result_t, run_holosym, words, any_line_contains
    implicit none
    private
    public :: double_double_tests

contains

    !> The tests of this suite.
    function double_double_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("kernels_agree_with_working_precision", kernels_agree), &
            new_test("runs_agree_with_working_sums", runs_agree), &
            new_test("automatic_where_the_tolerance_allows", automatic_choice), &
            new_test("refused_where_it_cannot_be_used", refusals), &
            new_test("cli_sums_option", cli_option)]
    end function double_double_tests

    !> Tables of (M, N, G) = (8, 7, 9)-like sizes with irrational entries, and an
    !! evaluation with displacements, gradients, forces and Phi values of mixed sizes.
    subroutine example_sums(tab, ev, qa, hwb, hw, mass_over_h, inv_mass, wl, rows, cols)
        type(reduced_tables), intent(out) :: tab
        type(reduced_evaluation), intent(out) :: ev
        real(wp), allocatable, intent(out) :: qa(:), hwb(:, :), hw(:), mass_over_h(:), &
            inv_mass(:), wl(:)
        integer, allocatable, intent(out) :: rows(:), cols(:)
        integer, parameter :: n = 3, m = 1, mm = 8, gg = 9
        real(wp), parameter :: h = 0.375_wp
        integer :: i, k, g, c
        allocate (tab%bt(mm, gg), tab%st(mm, 0:mm), tab%wb(gg, 0:mm), tab%w(gg), &
                  tab%wl(0:mm))
        do g = 1, gg
            tab%w(g) = 0.1_wp + sqrt(real(g, wp)) / 17
            do k = 1, mm
                tab%bt(k, g) = sin(real(3 * k + g, wp)) * 1.7_wp
            end do
            do i = 0, mm
                tab%wb(g, i) = tab%w(g) * cos(real(i + 2 * g, wp))
            end do
        end do
        do i = 0, mm
            tab%wl(i) = 1 / (7 + sqrt(real(i + 1, wp)))
            do k = 1, mm
                tab%st(k, i) = tan(real(k - i, wp) / 11) * 9
            end do
        end do
        call allocate_evaluation(ev, n, m, mm, gg, n)
        qa = [0.3_wp, -sqrt(0.5_wp), 1 / 3.0_wp]
        do c = 1, n
            do k = 1, mm
                ev%z(c, k) = 1.0e-2_wp * sin(real(5 * c + k, wp)) / 3
            end do
            do g = 1, gg
                ev%grad(c, g) = merge(0.0_wp, cos(real(c * g, wp)) * 7, c == 1)
            end do
            do i = 0, mm
                ev%t(c, i) = exp(-real(c + i, wp) / 5)
            end do
        end do
        ev%mu = 0.25_wp
        do i = 0, mm
            ev%pv(:, i) = 2 * (qa + 1.0e-3_wp * i)
        end do
        hwb = h * tab%wb
        hw = h * tab%w
        mass_over_h = [1.0_wp, 2.5_wp, 1 / 3.0_wp] / h
        inv_mass = h / mass_over_h
        wl = tab%wl
        rows = [1, 1, 1]
        cols = [1, 2, 3]
    end subroutine example_sums

    !> The double-double Gauss positions and node sums agree with the working-precision
    !! kernels to the pairs' rounding (2^-104 of the sums' terms): far below real64's.
    subroutine kernels_agree(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(reduced_tables) :: tab
        type(reduced_evaluation) :: ev, paired
        type(dd_tables_t) :: dd
        real(wp), allocatable :: qa(:), hwb(:, :), hw(:), mass_over_h(:), inv_mass(:), wl(:)
        integer, allocatable :: rows(:), cols(:)
        real(wp) :: bound, gap
        logical :: fits
        if (wp_is_double) then
            call skip(error, "double-double sums are for the real128 build")
            return
        end if
        call example_sums(tab, ev, qa, hwb, hw, mass_over_h, inv_mass, wl, rows, cols)
        paired = ev
        call gauss_positions(tab, qa, ev)
        call node_sums(tab, hwb, hw, mass_over_h, inv_mass, rows, cols, ev)
        call dd_tables_init(tab, size(qa), dd)
        call dd_step_tables(0.375_wp, mass_over_h, qa, dd, fits)
        call check(error, fits, "the tables fit the pairs' range")
        if (allocated(error)) return
        call dd_gauss_positions(dd, paired)
        call dd_node_sums(dd, wl, inv_mass, rows, cols, paired)
        ! The terms of the sums are at most about 100 (9 (M/h) |z| and 7 h |w B|): 2^-100
        ! of them bounds the pairs' rounding with room, and real64 sums would miss it by
        ! 1e-14.
        bound = 100 * 2.0_wp**(-100)
        gap = maxval(abs(paired%qg - ev%qg))
        call check(error, gap <= bound, "positions differ by " // real_str(gap))
        if (allocated(error)) return
        gap = max(maxval(abs(paired%d - ev%d)), maxval(abs(paired%dp - ev%dp)), &
                  maxval(abs(paired%v - ev%v)))
        call check(error, gap <= bound, "node sums differ by " // real_str(gap))
        if (allocated(error)) return
        call check(error, any(paired%d /= ev%d), "the double-double sums were computed " // &
            "(they differ from working precision in the last digits)")
    end subroutine kernels_agree

    !> Runs with double-double sums agree with working-precision sums within the Newton
    !! tolerance's effect (steps times tolerance), on built-in systems and a model file,
    !! and count their paired residuals.
    subroutine runs_agree(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(*) = [character(len=8) :: "pendulum", &
            "linkage", "planar", "chain4"]
        class(constrained_hamiltonian), allocatable :: sys
        type(formula_model) :: model
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:)
        integer :: k
        if (wp_is_double) then
            call skip(error, "double-double sums are for the real128 build")
            return
        end if
        do k = 1, size(names)
            call builtin_system(trim(names(k)), sys, q, p)
            call compare_runs(sys, q, p, trim(names(k)), error)
            if (allocated(error)) return
        end do
        call load_model("example/models/fourbar.hsm", model, status)
        call check(error, status%ok(), status%message)
        if (allocated(error)) return
        deallocate (q, p)
        allocate (q(model%n), p(model%n))
        call model%initial_state(q, p, status)
        call compare_runs(model, q, p, "fourbar model", error)
    end subroutine runs_agree

    !> 40 steps of (6, 5, 7), h = 1/8, Newton tolerance 1e-26, working and double-double
    !! sums: the end states within 40 x 1e-26 x (1 + |state|) of each other, the paired
    !! run's every working-precision residual paired, the other's none.
    subroutine compare_runs(sys, q, p, name, error)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        character(len=*), intent(in) :: name
        type(test_error_t), allocatable, intent(inout) :: error
        type(constrained_integrator) :: plain, paired
        type(holosym_status_t) :: status
        real(wp) :: qa(size(q)), pa(size(p)), qb(size(q)), pb(size(p)), gap, scale
        integer, parameter :: steps = 40
        real(wp), parameter :: tolerance = 1.0e-26_wp
        qa = q
        pa = p
        qb = q
        pb = p
        plain%newton%tolerance = tolerance
        plain%residual_sums = "working"
        paired%newton%tolerance = tolerance
        paired%residual_sums = "double-double"
        ! Without the general step's fallback: a paired step that fails must show.
        plain%general_fallback = .false.
        paired%general_fallback = .false.
        call plain%init(sys, 6, 5, 7, status)
        call paired%init(sys, 6, 5, 7, status)
        call plain%integrate(sys, qa, pa, 0.125_wp, steps, status=status)
        call check(error, status%ok(), name // " working: " // status%message)
        if (allocated(error)) return
        call paired%integrate(sys, qb, pb, 0.125_wp, steps, status=status)
        call check(error, status%ok(), name // " double-double: " // status%message)
        if (allocated(error)) return
        scale = 1 + max(maxval(abs(qa)), maxval(abs(pa)))
        gap = max(maxval(abs(qa - qb)), maxval(abs(pa - pb)))
        call check(error, gap <= steps * tolerance * scale, name // ": the runs differ by " &
            // real_str(gap))
        if (allocated(error)) return
        call check(error, plain%stats%paired_residual_evaluations == 0, name // &
            ": working sums paired none")
        if (allocated(error)) return
        call check(error, paired%stats%paired_residual_evaluations > 0, name // &
            ": double-double sums paired " // int_str(int(paired%stats% &
            paired_residual_evaluations)) // " of " // int_str(int(paired%stats% &
            residual_evaluations)) // " residuals")
    end subroutine compare_runs

    !> `automatic` (the default) pairs the sums at a Newton tolerance of at least the floor
    !! in real128, and never at the default tolerance or in real64.
    subroutine automatic_choice(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), q0(:), p0(:)
        integer :: k
        call builtin_system("pendulum", sys, q0, p0)
        call check(error, integ%residual_sums == "automatic", "the default is automatic")
        if (allocated(error)) return
        do k = 1, 2
            q = q0
            p = p0
            if (k == 2) integ%newton%tolerance = 4 * double_double_floor
            call integ%init(sys, 8, 7, 9, status)
            call integ%integrate(sys, q, p, 0.25_wp, 20, status=status)
            call check(error, status%ok(), status%message)
            if (allocated(error)) return
            if (k == 1 .or. wp_is_double) then
                call check(error, integ%stats%paired_residual_evaluations == 0, &
                    "no paired sums at tolerance " // real_str(integ%newton%tolerance))
            else
                call check(error, integ%stats%paired_residual_evaluations > 0, &
                    "paired sums at tolerance " // real_str(integ%newton%tolerance))
            end if
            if (allocated(error)) return
        end do
    end subroutine automatic_choice

    !> An explicit 'double-double' below the tolerance floor, on the general step or in
    !! real64, and an unknown value, are refused by name, the state unchanged.
    subroutine refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q(:), p(:)
        call builtin_system("pendulum", sys, q, p)
        if (wp_is_double) then
            call expect(.true., 8 * epsilon(1.0_wp), "double-double", "for the real128 build")
            call expect(.false., 1.0e-20_wp, "double-double", "for the real128 build")
        else
            call expect(.true., 8 * epsilon(1.0_wp), "double-double", "needs newton%tolerance")
            call expect(.false., 1.0e-20_wp, "double-double", "needs the reduced step")
        end if
        call expect(.true., 1.0e-20_wp, "quad", "must be 'automatic', 'working' or")
    contains
        subroutine expect(structured, tolerance, value, words)
            logical, intent(in) :: structured
            real(wp), intent(in) :: tolerance
            character(len=*), intent(in) :: value, words
            type(constrained_integrator) :: integ
            type(holosym_status_t) :: status
            real(wp) :: qs(size(q)), ps(size(p))
            if (allocated(error)) return
            qs = q
            ps = p
            integ%structured = structured
            integ%newton%tolerance = tolerance
            integ%residual_sums = value
            call integ%init(sys, 4, 3, 5, status)
            call integ%step(sys, qs, ps, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
                value // ": " // status%message)
            if (allocated(error)) return
            call check(error, index(status%message, trim(words)) > 0 .and. &
                index(status%message, "residual_sums") > 0, "the message names it: " // &
                status%message)
            if (allocated(error)) return
            call check(error, all(qs == q) .and. all(ps == p), "the state unchanged")
        end subroutine expect
    end subroutine refusals

    !> `holosym simulate --sums`: through --accuracy at 1e-20 (real64: 1e-10, where
    !! nothing is paired) the default sums the run's residuals in pairs and `--sums
    !! working` none, as the summaries count; 'double-double' at the default Newton
    !! tolerance and an unknown value are refused, naming the option.
    subroutine cli_option(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: automatic, working, strict, bad
        character(len=*), parameter :: run = "simulate --system pendulum --accuracy " // &
            merge("1e-10", "1e-20", wp_is_double) // " --T 2 --every 100000000"
        call run_holosym(run, automatic)
        call run_holosym(run // " --sums working", working)
        call run_holosym("simulate --system pendulum --steps 2 --sums double-double", strict)
        call run_holosym(words("simulate", "--system", "pendulum", "--sums", "quad"), bad)
        call check(error, automatic%exit_code == 0 .and. working%exit_code == 0, &
            "exit codes " // int_str(automatic%exit_code) // ", " // &
            int_str(working%exit_code))
        if (allocated(error)) return
        call check(error, any_line_contains(working%err, " 0 residuals summed in " // &
            "double-double") .and. (wp_is_double .neqv. .not. any_line_contains( &
            automatic%err, " 0 residuals summed in double-double")), &
            "the summaries count the paired residuals")
        if (allocated(error)) return
        call check(error, strict%exit_code /= 0 .and. any_line_contains(strict%err, &
            "residual_sums = 'double-double'"), "double-double at 8 epsilon: exit " // &
            int_str(strict%exit_code))
        if (allocated(error)) return
        call check(error, bad%exit_code == 2 .and. any_line_contains(bad%err, "--sums"), &
            "unknown value: exit " // int_str(bad%exit_code))
    end subroutine cli_option

end module test_double_double
