!> Tests of the scheme part of holosym: equation count, residual, Jacobian, solution.
module test_scheme
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION
    use holosym_quadrature, only: gauss_lobatto, gauss_legendre
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: newton_settings_t, newton_report_t, newton_solve
    use holosym_scheme, only: discrete_scheme, unknown_count
    use holosym_integrator, only: constrained_integrator
    use holosym_models, only: spherical_pendulum, spring_linkage
    use holosym_scheme_kernels_wp, only: template_sha256_wp => template_sha256
    use holosym_scheme_kernels_dp, only: template_sha256_dp => template_sha256
    use holosym_reduced_kernels_wp, only: reduced_sha256_wp => template_sha256
    use holosym_reduced_kernels_dp, only: reduced_sha256_dp => template_sha256
    use holosym_tape_kernels_wp, only: tape_sha256_wp => template_sha256
    use holosym_tape_kernels_dp, only: tape_sha256_dp => template_sha256
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code, skip
    use holosym_test_commands, only: file_exists, file_sha256
    implicit none
    private
    public :: scheme_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Residual accepted at a converged solution (about 1e-30).
    real(wp), parameter :: solution_tolerance = 4096 * eps

    !> A particle in the plane under a constant force, held on the line q_2 = 0:
    !! H = |p|^2/2 + f_1 q_1 + f_2 q_2, phi = q_2. Its exact motion is polynomial
    !! (q_1 quadratic, p_1 linear, lambda = -f_2), so for M >= 2, N >= 1 the discrete
    !! solution is known in closed form.
    type, extends(constrained_hamiltonian) :: line_particle
        real(wp) :: force(2) = [1.5_wp, 2.5_wp] !! constant force -dV/dq = -force
    contains
        procedure :: hamiltonian => line_hamiltonian
        procedure :: dh_dq => line_dh_dq
        procedure :: dh_dp => line_dh_dp
        procedure :: constraint => line_constraint
        procedure :: constraint_jacobian => line_constraint_jacobian
    end type line_particle

    abstract interface
        !> One case of the lowered-evaluation tests.
        subroutine lowered_case(error, sys, q, p, order_m, order_n, gauss_points)
            import :: test_error_t, constrained_hamiltonian, wp
            type(test_error_t), allocatable, intent(inout) :: error
            class(constrained_hamiltonian), intent(in), target :: sys
            real(wp), intent(in) :: q(:), p(:)
            integer, intent(in) :: order_m, order_n, gauss_points
        end subroutine lowered_case
    end interface

contains

    ! Functions, not named constants: not every compiler folds real128 powers.

    !> Relative step of the central differences: eps**(1/3) (about 6e-12 in real128).
    pure real(wp) function fd_step()
        fd_step = eps**(1.0_wp / 3)
    end function fd_step

    !> Agreement required between the Jacobian and central differences (about 3e-19):
    !! both carry errors of order eps**(2/3) (about 3e-23), so this leaves a wide margin.
    pure real(wp) function fd_tolerance()
        fd_tolerance = 1.0e4_wp * eps**(2.0_wp / 3)
    end function fd_tolerance

    !> The tests of this suite.
    function scheme_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("equation_count_equals_unknowns_grid", equation_count_grid), &
            new_test("init_rejects_bad_orders", init_bad_orders), &
            new_test("init_rejects_bad_dimensions", init_bad_dimensions), &
            new_test("init_nodes_and_basis_matrices", init_nodes_and_matrices), &
            new_test("jacobian_matches_differences_pendulum", jacobian_fd_pendulum), &
            new_test("jacobian_matches_differences_linkage", jacobian_fd_linkage), &
            new_test("jacobian_independent_of_cache", jacobian_cache), &
            new_test("lowered_residual_matches_to_real64", lowered_residual), &
            new_test("lowered_jacobian_matches_to_real64", lowered_jacobian), &
            new_test("lowered_evaluation_not_reused_by_residual", lowered_cache), &
            new_test("residual_zero_at_exact_polynomial_solution", residual_exact_solution), &
            new_test("residual_nonzero_off_solution", residual_off_solution), &
            new_test("newton_finds_exact_polynomial_solution", newton_exact_solution), &
            new_test("increments_and_dense_of_exact_solution", increments_and_dense), &
            new_test("extrapolated_guess_continues_polynomial", extrapolated_guess), &
            new_test("converged_residual_round_off_pendulum", converged_pendulum), &
            new_test("converged_residual_round_off_linkage", converged_linkage), &
            new_test("solution_matches_integrator_step", matches_integrator_step), &
            new_test("kernels_compiled_from_current_template", kernels_template_current) &
            ]
    end function scheme_tests

    !> Both instances of each kernel template were compiled from the template now in
    !! include/: each records the template's SHA-256, and fpm rebuilds a module only when
    !! its own source changes, so an edit of the template without tools/include_digest.sh
    !! (run by make) shows here.
    subroutine kernels_template_current(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check_template(error, "include/holosym_scheme_kernels.inc", template_sha256_wp, &
                            template_sha256_dp)
        call check_template(error, "include/holosym_reduced_kernels.inc", reduced_sha256_wp, &
                            reduced_sha256_dp)
        call check_template(error, "include/holosym_tape_kernels.inc", tape_sha256_wp, &
                            tape_sha256_dp)
    end subroutine kernels_template_current

    !> The digests compiled into a template's two instances equal the file's.
    subroutine check_template(error, template, recorded_wp, recorded_dp)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: template, recorded_wp, recorded_dp
        character(len=:), allocatable :: digest
        if (allocated(error)) return
        call check(error, file_exists(template), template // " not found: run the tests " // &
            "from the repository root")
        if (allocated(error)) return
        digest = file_sha256(template)
        if (len(digest) == 0) then
            call skip(error, "sha256sum is not available")
            return
        end if
        call check(error, recorded_wp == digest .and. recorded_dp == digest, &
            "the kernel modules were compiled from an older " // template // " (recorded " // &
            recorded_wp // ", " // recorded_dp // "; the file has " // digest // &
            "): run tools/include_digest.sh, or make, and rebuild")
    end subroutine check_template

    ! ------------------------------------------------------------------ the line particle

    !> H = |p|^2/2 + force . q.
    function line_hamiltonian(self, q, p) result(energy)
        class(line_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp) :: energy
        energy = sum(p**2) / 2 + sum(self%force * q)
    end function line_hamiltonian

    !> dH/dq = force.
    subroutine line_dh_dq(self, q, p, gradient)
        class(line_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp), intent(out) :: gradient(:)     !! dH/dq
        gradient = self%force
    end subroutine line_dh_dq

    !> dH/dp = p.
    subroutine line_dh_dp(self, q, p, gradient)
        class(line_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp), intent(out) :: gradient(:)     !! dH/dp
        gradient = p
    end subroutine line_dh_dp

    !> phi = q_2.
    subroutine line_constraint(self, q, phi)
        class(line_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(out) :: phi(:)          !! constraint value
        phi(1) = q(2)
    end subroutine line_constraint

    !> Phi = (0, 1).
    subroutine line_constraint_jacobian(self, q, jacobian)
        class(line_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(out) :: jacobian(:, :)  !! 1 x 2
        jacobian(1, :) = [0.0_wp, 1.0_wp]
    end subroutine line_constraint_jacobian

    !> A line particle (n = 2, m = 1).
    function new_line_particle() result(sys)
        type(line_particle) :: sys
        sys%n = 2
        sys%m = 1
    end function new_line_particle

    !> Exact solution x of one step of the line particle from (q_a, p_a) with h, in the
    !! scheme's layout (z_1..z_M, w_0..w_N, mu_0..mu_M), from independently computed nodes.
    !! The unknowns are increments, so q_a (any point of the line) does not enter.
    function line_exact_x(sys, order_m, order_n, pa, h) result(x)
        type(line_particle), intent(in) :: sys !! the system
        integer, intent(in) :: order_m !! M >= 2
        integer, intent(in) :: order_n !! N >= 1
        real(wp), intent(in) :: pa(2)  !! start momenta (p_2 = 0)
        real(wp), intent(in) :: h      !! step size
        real(wp), allocatable :: x(:)
        real(wp) :: d(0:order_m), dw(0:order_m), c(0:order_n), cw(0:order_n), t
        integer :: i, j, base
        call gauss_lobatto(d, dw)
        call gauss_lobatto(c, cw)
        allocate (x(unknown_count(order_m, order_n, 2, 1)))
        do i = 1, order_m
            t = d(i) * h
            x(2 * i - 1:2 * i) = [pa(1) * t - sys%force(1) * t**2 / 2, 0.0_wp]
        end do
        do j = 0, order_n
            base = 2 * (order_m + j)
            x(base + 1:base + 2) = [-sys%force(1) * c(j) * h, 0.0_wp]
        end do
        base = 2 * (order_m + order_n + 1)
        x(base + 1:base + order_m + 1) = -h * sys%force(2)
    end function line_exact_x

    ! ------------------------------------------------------------------ helpers

    !> Seed the intrinsic generator with a fixed seed (reproducible tests).
    subroutine fixed_seed(offset)
        integer, intent(in) :: offset !! distinguishes the tests' streams
        integer :: n, i
        integer, allocatable :: seed(:)
        call random_seed(size=n)
        allocate (seed(n))
        seed = [(7727 * i + 3571 * offset + 271828, i = 1, n)]
        call random_seed(put=seed)
    end subroutine fixed_seed

    !> Set up a scheme, bind a step and check the set-up succeeded.
    subroutine setup(error, scheme, sys, order_m, order_n, gauss_points, qa, pa, h)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        type(discrete_scheme), intent(inout) :: scheme   !! fresh scheme
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        integer, intent(in) :: order_m       !! M
        integer, intent(in) :: order_n       !! N
        integer, intent(in) :: gauss_points  !! G
        real(wp), intent(in) :: qa(:)        !! start coordinates
        real(wp), intent(in) :: pa(:)        !! start momenta
        real(wp), intent(in) :: h            !! step size
        type(holosym_status_t) :: status
        call scheme%init(order_m, order_n, gauss_points, sys%n, sys%m, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "scheme%init")
        if (allocated(error)) return
        call scheme%set_step(sys, qa, pa, h)
    end subroutine setup

    !> Text "(M, N, G) = (a, b, c)" for messages.
    function orders_str(order_m, order_n, gauss_points) result(text)
        integer, intent(in) :: order_m      !! M
        integer, intent(in) :: order_n      !! N
        integer, intent(in) :: gauss_points !! G
        character(len=:), allocatable :: text
        text = "(M, N, G) = (" // int_str(order_m) // ", " // int_str(order_n) // ", " // &
            int_str(gauss_points) // ")"
    end function orders_str

    !> Solve the bound step by Newton from the constant guess; x is the solution.
    subroutine solve(scheme, qa, pa, x, status)
        type(discrete_scheme), intent(inout) :: scheme !! scheme with a bound step
        real(wp), intent(in) :: qa(:)  !! start coordinates
        real(wp), intent(in) :: pa(:)  !! start momenta
        real(wp), intent(out) :: x(:)  !! solution
        type(holosym_status_t), intent(out) :: status !! outcome
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        call scheme%constant_guess(x)
        call newton_solve(scheme, x, settings, max(maxval(abs(qa)), maxval(abs(pa))), report, &
            status)
    end subroutine solve

    ! ------------------------------------------------------------------ counting

    !> For M = 1..8, N = 0..8 and (n, m) of both paper systems: the rows of docs/method.md
    !! section 3, counted block by block, equal the unknowns, unknown_count and nx; the
    !! residual fills all nx rows and the Jacobian all nx x nx entries.
    subroutine equation_count_grid(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: pendulum
        type(spring_linkage), target :: linkage
        real(wp) :: qp(3), pp(3), ql(6), pl(6)
        integer :: order_m, order_n
        pendulum = spherical_pendulum()
        linkage = spring_linkage()
        call pendulum%initial_state(qp, pp)
        call linkage%initial_state(ql, pl)
        do order_m = 1, 8
            do order_n = 0, 8
                call count_one(pendulum, qp, pp, "pendulum")
                if (allocated(error)) return
                call count_one(linkage, ql, pl, "linkage")
                if (allocated(error)) return
            end do
        end do

    contains

        subroutine count_one(sys, qa, pa, label)
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: qa(:)          !! start coordinates
            real(wp), intent(in) :: pa(:)          !! start momenta
            character(len=*), intent(in) :: label  !! system name
            type(discrete_scheme) :: scheme
            type(holosym_status_t) :: status
            real(wp), allocatable :: x(:), f(:), jac(:, :)
            integer :: n, m, rows, unknowns, gauss_points
            character(len=:), allocatable :: where
            n = sys%n
            m = sys%m
            gauss_points = max(order_m, order_n) + 1
            where = label // " " // orders_str(order_m, order_n, gauss_points)
            ! R_p,j (j = 0..N), D_i (i = 1..M-1), R_a, phi(q_i) (i = 1..M), R_v.
            rows = (order_n + 1) * n + (order_m - 1) * n + n + order_m * m + m
            ! q_1..q_M, p_0..p_N, lambda_0..lambda_M.
            unknowns = order_m * n + (order_n + 1) * n + (order_m + 1) * m
            call check(error, rows == unknowns, where // ": rows " // int_str(rows) // &
                " /= unknowns " // int_str(unknowns))
            call check(error, unknown_count(order_m, order_n, n, m) == rows, where // &
                ": unknown_count = " // int_str(unknown_count(order_m, order_n, n, m)) // &
                ", rows = " // int_str(rows))
            call setup(error, scheme, sys, order_m, order_n, gauss_points, qa, pa, 0.125_wp)
            if (allocated(error)) return
            call check(error, scheme%nx == rows, where // ": nx = " // int_str(scheme%nx))
            if (allocated(error)) return
            allocate (x(scheme%nx), f(scheme%nx), jac(scheme%nx, scheme%nx))
            call scheme%constant_guess(x)
            call check(error, all(x == 0), where // ": constant guess is not all zero")
            f = ieee_value(1.0_wp, ieee_quiet_nan)
            call scheme%residual(x, f, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": residual")
            call check(error, all(f == f), where // ": residual left rows unset (NaN)")
            jac = ieee_value(1.0_wp, ieee_quiet_nan)
            call scheme%jacobian(x, jac, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": jacobian")
            call check(error, all(jac == jac), where // ": Jacobian left entries unset (NaN)")
        end subroutine count_one

    end subroutine equation_count_grid

    !> init rejects M < 1, N < 0, G < 1 with HOLOSYM_INVALID_ORDER naming the values.
    subroutine init_bad_orders(error)
        type(test_error_t), allocatable, intent(out) :: error
        call one(0, 1, 2, "M = 0")
        call one(-3, 1, 2, "M = -3")
        call one(2, -1, 3, "N = -1")
        call one(2, 1, 0, "G = 0")
        call one(2, 1, -2, "G = -2")

    contains

        subroutine one(order_m, order_n, gauss_points, expected_text)
            integer, intent(in) :: order_m, order_n, gauss_points
            character(len=*), intent(in) :: expected_text
            type(discrete_scheme) :: scheme
            type(holosym_status_t) :: status
            if (allocated(error)) return
            call scheme%init(order_m, order_n, gauss_points, 3, 1, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, &
                "init " // orders_str(order_m, order_n, gauss_points))
            if (allocated(error)) return
            call check(error, index(status%message, expected_text) > 0, "message '" // &
                status%message // "' does not contain '" // expected_text // "'")
        end subroutine one

    end subroutine init_bad_orders

    !> init rejects n < 1, m < 0, m >= n with HOLOSYM_INVALID_DIMENSION naming the values.
    subroutine init_bad_dimensions(error)
        type(test_error_t), allocatable, intent(out) :: error
        call one(0, 0, "n = 0")
        call one(3, -1, "m = -1")
        call one(3, 3, "m = 3")
        call one(2, 5, "m = 5")

    contains

        subroutine one(n, m, expected_text)
            integer, intent(in) :: n, m
            character(len=*), intent(in) :: expected_text
            type(discrete_scheme) :: scheme
            type(holosym_status_t) :: status
            if (allocated(error)) return
            call scheme%init(2, 1, 3, n, m, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, &
                "init with n = " // int_str(n) // ", m = " // int_str(m))
            if (allocated(error)) return
            call check(error, index(status%message, expected_text) > 0, "message '" // &
                status%message // "' does not contain '" // expected_text // "'")
        end subroutine one

    end subroutine init_bad_dimensions

    !> The scheme's nodes are the Lobatto/Gauss rules (N = 0: c_0 = 1/2), and its basis
    !! matrices satisfy sum_i B_gi = 1, sum_i A_gi = 0, sum_j C_gj = 1, sum_g w_g B_gi = wl_i.
    subroutine init_nodes_and_matrices(error)
        type(test_error_t), allocatable, intent(out) :: error
        call one(1, 0, 1)
        call one(3, 2, 4)
        call one(4, 0, 3)
        call one(2, 5, 6)

    contains

        subroutine one(order_m, order_n, gauss_points)
            integer, intent(in) :: order_m, order_n, gauss_points
            type(discrete_scheme) :: scheme
            type(holosym_status_t) :: status
            real(wp) :: d(0:order_m), dw(0:order_m), tg(gauss_points), wg(gauss_points)
            real(wp) :: c(0:max(order_n, 1)), cw(0:max(order_n, 1))
            integer :: g, i
            character(len=:), allocatable :: where
            if (allocated(error)) return
            where = orders_str(order_m, order_n, gauss_points)
            call scheme%init(order_m, order_n, gauss_points, 3, 1, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where)
            if (allocated(error)) return
            call gauss_lobatto(d, dw)
            call gauss_legendre(tg, wg)
            call check(error, all(scheme%disp_nodes == d), where // ": displacement nodes")
            call check(error, all(scheme%lobatto_weights == dw), where // ": Lobatto weights")
            call check(error, all(scheme%gauss_nodes == tg), where // ": Gauss nodes")
            call check(error, all(scheme%gauss_weights == wg), where // ": Gauss weights")
            if (order_n == 0) then
                call check(error, size(scheme%mom_nodes) == 1, where // ": one momentum node")
                call check(error, scheme%mom_nodes(0) == 0.5_wp, where // ": c_0 /= 1/2")
            else
                call gauss_lobatto(c(0:order_n), cw(0:order_n))
                call check(error, all(scheme%mom_nodes == c(0:order_n)), where // &
                    ": momentum nodes")
            end if
            do g = 1, gauss_points
                call check_close(error, sum(scheme%b(g, :)), 1.0_wp, 0.0_wp, 64 * eps, &
                    where // ": row sum of B")
                call check_close(error, sum(scheme%a(g, :)), 0.0_wp, 0.0_wp, &
                    64 * eps * maxval(abs(scheme%a(g, :))), where // ": row sum of A")
                call check_close(error, sum(scheme%c(g, :)), 1.0_wp, 0.0_wp, 64 * eps, &
                    where // ": row sum of C")
            end do
            if (2 * gauss_points - 1 >= order_m) then
                do i = 0, order_m
                    call check_close(error, sum(scheme%gauss_weights * scheme%b(:, i)), &
                        scheme%lobatto_weights(i), 0.0_wp, 64 * eps, where // &
                        ": Gauss integral of rho_" // int_str(i))
                end do
            end if
        end subroutine one

    end subroutine init_nodes_and_matrices

    ! ------------------------------------------------------------------ Jacobian

    !> Compare the assembled Jacobian with central differences of the residual at a random
    !! x near the solution (Newton's solution when it converges, else the constant guess).
    subroutine check_jacobian_fd(error, sys, qa, pa, h, order_m, order_n, gauss_points, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        real(wp), intent(in) :: qa(:)        !! start coordinates
        real(wp), intent(in) :: pa(:)        !! start momenta
        real(wp), intent(in) :: h            !! step size
        integer, intent(in) :: order_m       !! M
        integer, intent(in) :: order_n       !! N
        integer, intent(in) :: gauss_points  !! G
        character(len=*), intent(in) :: label !! system name
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), shift(:), jac(:, :), fd(:, :), fp(:), fm(:), xs(:)
        real(wp) :: upper, lower, row_scale
        integer :: nx, i, j
        character(len=:), allocatable :: where
        where = label // " " // orders_str(order_m, order_n, gauss_points)
        call setup(error, scheme, sys, order_m, order_n, gauss_points, qa, pa, h)
        if (allocated(error)) return
        nx = scheme%nx
        allocate (x(nx), shift(nx), jac(nx, nx), fd(nx, nx), fp(nx), fm(nx))
        call solve(scheme, qa, pa, x, status)
        if (.not. status%ok()) call scheme%constant_guess(x)
        ! A random nonzero point near it (multipliers included, so phi'' enters).
        call random_number(shift)
        x = x + 1.0e-3_wp * (2 * shift - 1)
        call check(error, all(x /= 0), where // ": test point has a zero component")
        call scheme%jacobian(x, jac, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": jacobian")
        if (allocated(error)) return
        do j = 1, nx
            xs = x
            upper = x(j) + fd_step() * max(1.0_wp, abs(x(j)))
            lower = x(j) - fd_step() * max(1.0_wp, abs(x(j)))
            xs(j) = upper
            call scheme%residual(xs, fp, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": residual")
            xs(j) = lower
            call scheme%residual(xs, fm, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": residual")
            if (allocated(error)) return
            fd(:, j) = (fp - fm) / (upper - lower)
        end do
        do i = 1, nx
            row_scale = max(maxval(abs(jac(i, :))), maxval(abs(fd(i, :))))
            call check(error, row_scale > 0, where // ": row " // int_str(i) // " is zero")
            if (allocated(error)) return
            call check(error, maxval(abs(jac(i, :) - fd(i, :))) <= fd_tolerance() * row_scale, &
                where // ": Jacobian row " // int_str(i) // " of " // int_str(nx) // &
                " differs from central differences by " // &
                real_str(maxval(abs(jac(i, :) - fd(i, :))) / row_scale) // " (relative)")
            if (allocated(error)) return
        end do
    end subroutine check_jacobian_fd

    !> The configurations of the Jacobian tests: M = 1, N = 0; M = N + 1; M = N; M > N + 1;
    !! G both minimal and larger.
    subroutine jacobian_configurations(error, sys, qa, pa, h, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        real(wp), intent(in) :: qa(:)   !! start coordinates
        real(wp), intent(in) :: pa(:)   !! start momenta
        real(wp), intent(in) :: h       !! step size
        character(len=*), intent(in) :: label !! system name
        integer, parameter :: configs(3, 9) = reshape([1, 0, 1, 1, 0, 2, 2, 1, 2, 2, 1, 3, &
            3, 2, 4, 1, 1, 2, 2, 2, 3, 3, 1, 4, 4, 3, 5], [3, 9])
        integer :: k
        do k = 1, size(configs, 2)
            call check_jacobian_fd(error, sys, qa, pa, h, configs(1, k), configs(2, k), &
                configs(3, k), label)
            if (allocated(error)) return
        end do
    end subroutine jacobian_configurations

    !> Jacobian against central differences, spherical pendulum.
    subroutine jacobian_fd_pendulum(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call fixed_seed(1)
        call jacobian_configurations(error, sys, q, p, 0.25_wp, "pendulum")
    end subroutine jacobian_fd_pendulum

    !> Jacobian against central differences, spring-linkage mechanism.
    subroutine jacobian_fd_linkage(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage), target :: sys
        real(wp) :: q(6), p(6)
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call fixed_seed(2)
        call jacobian_configurations(error, sys, q, p, 0.5_wp, "linkage")
    end subroutine jacobian_fd_linkage

    !> The Jacobian at x is the same (bit for bit) whether x was just evaluated by the
    !! residual (cached workspace) or not.
    subroutine jacobian_cache(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage), target :: sys
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp) :: q(6), p(6)
        real(wp), allocatable :: x(:), y(:), f(:), cold(:, :), warm(:, :)
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call setup(error, scheme, sys, 3, 2, 4, q, p, 0.5_wp)
        if (allocated(error)) return
        allocate (x(scheme%nx), y(scheme%nx), f(scheme%nx))
        allocate (cold(scheme%nx, scheme%nx), warm(scheme%nx, scheme%nx))
        call fixed_seed(3)
        call random_number(x)
        x = 1.0e-2_wp * x
        call random_number(y)
        y = 1.0e-2_wp * y
        call scheme%jacobian(x, cold, status)
        call scheme%residual(y, f, status)
        call scheme%residual(x, f, status)
        call scheme%jacobian(x, warm, status)
        call check(error, all(cold == warm), "Jacobian depends on the evaluation cache")
        call scheme%jacobian(y, warm, status)
        call check(error, any(cold /= warm), "Jacobian at a different x is unchanged (stale cache)")
    end subroutine jacobian_cache

    !> Run `check_case` on the paper systems at (3,2,4) (linkage), (2,1,3) and (6,5,7)
    !! (pendulum).
    subroutine on_lowered_cases(error, check_case)
        type(test_error_t), allocatable, intent(inout) :: error
        procedure(lowered_case) :: check_case
        type(spring_linkage), target :: linkage
        type(spherical_pendulum), target :: sphere
        real(wp) :: q6(6), p6(6), q3(3), p3(3)
        linkage = spring_linkage()
        call linkage%initial_state(q6, p6)
        sphere = spherical_pendulum()
        call sphere%initial_state(q3, p3)
        call check_case(error, linkage, q6, p6, 3, 2, 4)
        call check_case(error, sphere, q3, p3, 2, 1, 3)
        call check_case(error, sphere, q3, p3, 6, 5, 7)
    end subroutine on_lowered_cases

    !> A scheme for a step of h = 1/2 from (q, p) and a reproducible random x of size 1e-2.
    subroutine lowered_setup(error, scheme, sys, q, p, order_m, order_n, gauss_points, x)
        type(test_error_t), allocatable, intent(inout) :: error
        type(discrete_scheme), intent(inout) :: scheme
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:)
        integer, intent(in) :: order_m, order_n, gauss_points
        real(wp), allocatable, intent(out) :: x(:)
        call setup(error, scheme, sys, order_m, order_n, gauss_points, q, p, 0.5_wp)
        if (allocated(error)) return
        allocate (x(scheme%nx))
        call fixed_seed(11)
        call random_number(x)
        x = 1.0e-2_wp * (x - 0.5_wp)
    end subroutine lowered_setup

    !> residual_lowered (sums in real64) equals residual to real64 round-off, on both paper
    !! systems and several orders, and is not identical to it in real128 (it is lowered).
    subroutine lowered_residual(error)
        type(test_error_t), allocatable, intent(out) :: error
        call on_lowered_cases(error, residual_case)
    end subroutine lowered_residual

    !> One case of `lowered_residual`.
    subroutine residual_case(error, sys, q, p, order_m, order_n, gauss_points)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:)
        integer, intent(in) :: order_m, order_n, gauss_points
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), exact(:), lowered(:)
        real(wp) :: difference, size_f
        call lowered_setup(error, scheme, sys, q, p, order_m, order_n, gauss_points, x)
        if (allocated(error)) return
        allocate (exact(scheme%nx), lowered(scheme%nx))
        call scheme%residual(x, exact, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "residual")
        call scheme%residual_lowered(x, lowered, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "residual_lowered")
        if (allocated(error)) return
        difference = maxval(abs(exact - lowered))
        size_f = max(maxval(abs(exact)), maxval(abs(p)), 1.0_wp)
        call check(error, difference <= 1.0e3_wp * epsilon(1.0_dp) * size_f, &
            orders_str(order_m, order_n, gauss_points) // ": lowered residual differs by " &
            // real_str(difference))
        if (precision(1.0_wp) > precision(1.0_dp)) call check(error, difference > 0, &
            orders_str(order_m, order_n, gauss_points) // ": lowered residual is exact")
    end subroutine residual_case

    !> jacobian_lowered (assembled in real64 arithmetic) equals the working-precision
    !! Jacobian rounded, to real64 round-off, on both paper systems; also after a lowered
    !! evaluation at the same x.
    subroutine lowered_jacobian(error)
        type(test_error_t), allocatable, intent(out) :: error
        call on_lowered_cases(error, jacobian_case)
    end subroutine lowered_jacobian

    !> One case of `lowered_jacobian`.
    subroutine jacobian_case(error, sys, q, p, order_m, order_n, gauss_points)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:)
        integer, intent(in) :: order_m, order_n, gauss_points
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), f(:), full(:, :)
        real(dp), allocatable :: lowered(:, :)
        real(wp) :: difference
        call lowered_setup(error, scheme, sys, q, p, order_m, order_n, gauss_points, x)
        if (allocated(error)) return
        allocate (f(scheme%nx), full(scheme%nx, scheme%nx), lowered(scheme%nx, scheme%nx))
        call scheme%jacobian(x, full, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "jacobian")
        call scheme%residual_lowered(x, f, status)
        call scheme%jacobian_lowered(x, lowered, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "jacobian_lowered")
        if (allocated(error)) return
        difference = maxval(abs(full - real(lowered, wp)))
        call check(error, difference <= 1.0e3_wp * epsilon(1.0_dp) * &
            max(1.0_wp, maxval(abs(full))), orders_str(order_m, order_n, gauss_points) &
            // ": real64 Jacobian differs by " // real_str(difference))
    end subroutine jacobian_case

    !> An evaluation cached by residual_lowered is not taken for the exact residual or the
    !! increments at the same x: they equal those of a scheme that never lowered.
    subroutine lowered_cache(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(discrete_scheme) :: scheme, fresh
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), dq(3), dp_(3), dq_fresh(3), dp_fresh(3)
        real(wp), allocatable :: x(:), f(:), f_fresh(:)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call setup(error, scheme, sys, 3, 2, 4, q, p, 0.25_wp)
        call setup(error, fresh, sys, 3, 2, 4, q, p, 0.25_wp)
        if (allocated(error)) return
        allocate (x(scheme%nx), f(scheme%nx), f_fresh(scheme%nx))
        call fixed_seed(12)
        call random_number(x)
        x = 1.0e-2_wp * x
        call scheme%residual_lowered(x, f, status)
        call scheme%residual(x, f, status)
        call fresh%residual(x, f_fresh, status)
        call check(error, all(f == f_fresh), "residual after residual_lowered differs")
        call scheme%residual_lowered(x, f, status)
        call scheme%increments(x, dq, dp_, status)
        call fresh%increments(x, dq_fresh, dp_fresh, status)
        call check(error, all(dq == dq_fresh) .and. all(dp_ == dp_fresh), &
            "increments after residual_lowered differ")
    end subroutine lowered_cache

    ! ------------------------------------------------------------------ exact solutions

    !> The closed-form solution of the line particle makes every residual row vanish to
    !! round-off, for several (M, N, G) with M >= 2, N >= 1, 2G - 1 >= M.
    subroutine residual_exact_solution(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: configs(3, 8) = reshape([2, 1, 2, 2, 1, 3, 3, 2, 4, 2, 2, 3, &
            3, 1, 2, 4, 1, 3, 4, 3, 5, 5, 6, 7], [3, 8])
        type(line_particle), target :: sys
        type(discrete_scheme), allocatable :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), f(:)
        real(wp), parameter :: qa(2) = [0.3_wp, 0.0_wp], pa(2) = [0.7_wp, 0.0_wp], h = 0.4_wp
        integer :: k
        sys = new_line_particle()
        do k = 1, size(configs, 2)
            allocate (scheme)
            call setup(error, scheme, sys, configs(1, k), configs(2, k), configs(3, k), qa, pa, h)
            if (allocated(error)) return
            x = line_exact_x(sys, configs(1, k), configs(2, k), pa, h)
            allocate (f(size(x)))
            call scheme%residual(x, f, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "residual")
            call check(error, maxval(abs(f)) <= 64 * eps, orders_str(configs(1, k), &
                configs(2, k), configs(3, k)) // ": max residual at the exact solution " // &
                real_str(maxval(abs(f))))
            if (allocated(error)) return
            deallocate (scheme, f)
        end do
    end subroutine residual_exact_solution

    !> Perturbing each single unknown of the exact solution makes the residual nonzero
    !! (every unknown enters some equation).
    subroutine residual_off_solution(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(line_particle), target :: sys
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), xs(:), f(:)
        real(wp), parameter :: qa(2) = [0.3_wp, 0.0_wp], pa(2) = [0.7_wp, 0.0_wp], h = 0.4_wp
        integer :: j
        sys = new_line_particle()
        call setup(error, scheme, sys, 3, 2, 4, qa, pa, h)
        if (allocated(error)) return
        x = line_exact_x(sys, 3, 2, pa, h)
        allocate (f(size(x)))
        do j = 1, size(x)
            xs = x
            xs(j) = xs(j) + 1.0e-3_wp
            call scheme%residual(xs, f, status)
            call check(error, maxval(abs(f)) > 1.0e-6_wp, "unknown " // int_str(j) // &
                " does not change the residual")
            if (allocated(error)) return
        end do
    end subroutine residual_off_solution

    !> Newton from the constant guess converges to the closed-form solution.
    subroutine newton_exact_solution(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: configs(3, 4) = reshape([2, 1, 3, 3, 2, 4, 2, 2, 3, 4, 3, 5], [3, 4])
        type(line_particle), target :: sys
        type(discrete_scheme), allocatable :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), exact(:)
        real(wp), parameter :: qa(2) = [0.3_wp, 0.0_wp], pa(2) = [0.7_wp, 0.0_wp], h = 0.4_wp
        integer :: k
        sys = new_line_particle()
        do k = 1, size(configs, 2)
            allocate (scheme)
            call setup(error, scheme, sys, configs(1, k), configs(2, k), configs(3, k), qa, pa, h)
            if (allocated(error)) return
            exact = line_exact_x(sys, configs(1, k), configs(2, k), pa, h)
            allocate (x(size(exact)))
            call solve(scheme, qa, pa, x, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "newton_solve " // &
                orders_str(configs(1, k), configs(2, k), configs(3, k)))
            call check(error, maxval(abs(x - exact)) <= 64 * eps, orders_str(configs(1, k), &
                configs(2, k), configs(3, k)) // ": Newton solution differs from the exact " // &
                "one by " // real_str(maxval(abs(x - exact))))
            if (allocated(error)) return
            deallocate (scheme, x)
        end do
    end subroutine newton_exact_solution

    !> From the exact solution: increments (q_b - q_a, p_b - p_a) and the dense polynomials
    !! q~, p~, lambda~ equal the exact motion.
    subroutine increments_and_dense(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(line_particle), target :: sys
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:)
        real(wp), parameter :: qa(2) = [0.3_wp, 0.0_wp], pa(2) = [0.7_wp, 0.0_wp], h = 0.4_wp
        real(wp) :: dq(2), dp(2), q(2), p(2), lambda(1), tau, t
        real(wp), parameter :: taus(5) = [0.0_wp, 0.2_wp, 0.5_wp, 0.9_wp, 1.0_wp]
        integer :: k
        sys = new_line_particle()
        call setup(error, scheme, sys, 3, 2, 4, qa, pa, h)
        if (allocated(error)) return
        x = line_exact_x(sys, 3, 2, pa, h)
        call scheme%increments(x, dq, dp, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "increments")
        call check_close(error, dq(1), pa(1) * h - sys%force(1) * h**2 / 2, 0.0_wp, 16 * eps, "dq1")
        call check_close(error, dq(2), 0.0_wp, 0.0_wp, 16 * eps, "dq2")
        call check_close(error, dp(1), -sys%force(1) * h, 0.0_wp, 16 * eps, "dp1")
        call check_close(error, dp(2), 0.0_wp, 0.0_wp, 16 * eps, "dp2 (multiplier cancels force)")
        do k = 1, size(taus)
            tau = taus(k)
            t = tau * h
            call scheme%dense(x, qa, pa, h, tau, q, p, lambda)
            call check_close(error, q(1), qa(1) + pa(1) * t - sys%force(1) * t**2 / 2, 0.0_wp, &
                16 * eps, "dense q1 at tau = " // real_str(tau))
            call check_close(error, q(2), 0.0_wp, 0.0_wp, 16 * eps, "dense q2")
            call check_close(error, p(1), pa(1) - sys%force(1) * t, 0.0_wp, 16 * eps, &
                "dense p1 at tau = " // real_str(tau))
            call check_close(error, lambda(1), -sys%force(2), 16 * eps, 0.0_wp, "dense lambda")
        end do
    end subroutine increments_and_dense

    !> Extrapolating the exact (globally polynomial) solution into the next step gives that
    !! step's exact solution, also when h changes.
    subroutine extrapolated_guess(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(line_particle), target :: sys
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), guess(:), exact(:)
        real(wp), parameter :: qa(2) = [0.3_wp, 0.0_wp], pa(2) = [0.7_wp, 0.0_wp], h = 0.4_wp
        real(wp) :: qb(2), pb(2), dq(2), dp(2), h_next
        integer :: k
        sys = new_line_particle()
        call setup(error, scheme, sys, 3, 2, 4, qa, pa, h)
        if (allocated(error)) return
        x = line_exact_x(sys, 3, 2, pa, h)
        call scheme%increments(x, dq, dp, status)
        qb = qa + dq
        pb = pa + dp
        allocate (guess(size(x)))
        do k = 1, 2
            h_next = merge(h, 0.25_wp, k == 1)
            call scheme%extrapolated_guess(x, qa, pa, h, qb, pb, h_next, guess)
            exact = line_exact_x(sys, 3, 2, pb, h_next)
            call check(error, maxval(abs(guess - exact)) <= 256 * eps, "h_next = " // &
                real_str(h_next) // ": extrapolated guess differs from the exact next step by " &
                // real_str(maxval(abs(guess - exact))))
        end do
    end subroutine extrapolated_guess

    ! ------------------------------------------------------------------ converged solutions

    !> Newton's solution of the paper models leaves a residual at round-off (<= ~1e-30).
    subroutine check_converged(error, sys, qa, pa, h, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        real(wp), intent(in) :: qa(:)   !! start coordinates
        real(wp), intent(in) :: pa(:)   !! start momenta
        real(wp), intent(in) :: h       !! step size
        character(len=*), intent(in) :: label !! system name
        integer, parameter :: configs(3, 5) = reshape([1, 0, 1, 1, 0, 2, 2, 1, 3, 3, 2, 4, &
            5, 4, 6], [3, 5])
        type(discrete_scheme), allocatable :: scheme
        type(holosym_status_t) :: status
        real(wp), allocatable :: x(:), f(:)
        integer :: k
        character(len=:), allocatable :: where
        do k = 1, size(configs, 2)
            where = label // " " // orders_str(configs(1, k), configs(2, k), configs(3, k))
            allocate (scheme)
            call setup(error, scheme, sys, configs(1, k), configs(2, k), configs(3, k), qa, pa, h)
            if (allocated(error)) return
            allocate (x(scheme%nx), f(scheme%nx))
            call solve(scheme, qa, pa, x, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": newton_solve")
            call check(error, any(x /= 0), where // ": trivial solution")
            call scheme%residual(x, f, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, where // ": residual")
            call check(error, maxval(abs(f)) <= solution_tolerance, where // &
                ": residual at the solution " // real_str(maxval(abs(f))))
            if (allocated(error)) return
            deallocate (scheme, x, f)
        end do
    end subroutine check_converged

    !> Converged residual, spherical pendulum (h = 1/8).
    subroutine converged_pendulum(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call check_converged(error, sys, q, p, 0.125_wp, "pendulum")
    end subroutine converged_pendulum

    !> Converged residual, spring-linkage mechanism (h = 1/2).
    subroutine converged_linkage(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage), target :: sys
        real(wp) :: q(6), p(6)
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call check_converged(error, sys, q, p, 0.5_wp, "linkage")
    end subroutine converged_linkage

    !> The scheme's solution gives the same (q_b, p_b) as the public integrator's step.
    subroutine matches_integrator_step(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(discrete_scheme) :: scheme
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: qa(3), pa(3), q(3), p(3), dq(3), dp(3)
        real(wp), allocatable :: x(:), f(:)
        integer :: i
        sys = spherical_pendulum()
        call sys%initial_state(qa, pa)
        call setup(error, scheme, sys, 2, 1, 3, qa, pa, 0.125_wp)
        if (allocated(error)) return
        allocate (x(scheme%nx), f(scheme%nx))
        call solve(scheme, qa, pa, x, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "newton_solve")
        call scheme%increments(x, dq, dp, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "increments")
        call integ%init(sys, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "integ%init")
        q = qa
        p = pa
        call integ%step(sys, q, p, 0.125_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "integ%step")
        if (allocated(error)) return
        do i = 1, 3
            call check_close(error, q(i), qa(i) + dq(i), 4 * eps, 4 * eps, "q_b(" // &
                int_str(i) // ")")
            call check_close(error, p(i), pa(i) + dp(i), 4 * eps, 4 * eps, "p_b(" // &
                int_str(i) // ")")
        end do
        call check(error, maxval(abs(q - qa)) > 1.0e-3_wp, "the step did not move")
    end subroutine matches_integrator_step

end module test_scheme
