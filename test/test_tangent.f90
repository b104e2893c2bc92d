!> Tests of the tangent map (`step_tangent`): the derivative of the equations against the
!! assembled Newton matrix, the derivative of the step map against fourth-order
!! differences of the step map, symplecticity on the tangent space of the manifold over
!! many steps, the same derivative on both paths, and bad tangent vectors refused with
!! nothing changed.
module test_tangent
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_OFF_MANIFOLD, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_NOT_INITIALIZED
    use holosym_problem, only: constrained_hamiltonian
    use holosym_models, only: spherical_pendulum, spring_linkage
    use holosym_test_systems, only: paper_start
    use holosym_scheme, only: discrete_scheme
    use holosym_integrator, only: constrained_integrator
    use holosym_tangent_space, only: project_tangent, tangent_residual, tangent_tolerance, &
        tangent_basis
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: tangent_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Difference step of the fourth-order central differences: eps^(1/5) balances their
    !! truncation (step^4) and their rounding (eps / step); a quarter of it, because the
    !! linkage's truncation error is large at eps^(1/5) (5e-24 in real128; 1e-21 at four
    !! times the step, the step^4 law).
    real(wp), parameter :: difference_step = eps**0.2_wp / 4
    !> Agreement required of the differences: 1e3 eps^(4/5) (4e-25 in real128), the
    !! differences' own accuracy with room for the Newton tolerance of each step.
    real(wp), parameter :: difference_tolerance = 1.0e3_wp * eps**0.8_wp
    !> Symplecticity required on the tangent space (real128: 1e-28; real64: its round-off
    !! over the steps of the test).
    real(wp), parameter :: symplectic_tolerance = max(1.0e-28_wp, 1.0e4_wp * eps)

contains

    !> The tests of this suite.
    function tangent_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("equations_derivative_matches_newton_matrix", newton_matrix), &
            new_test("matches_differences_of_the_step_map", differences), &
            new_test("symplectic_on_the_tangent_space", symplectic), &
            new_test("same_on_both_paths", both_paths), &
            new_test("project_tangent_projects", projection), &
            new_test("bad_tangent_vectors_refused", refusals) &
        ]
    end function tangent_tests

    !> The derivative of the step equations along y (written from the formulas) equals the
    !! assembled Newton matrix times y, at a point that is not a solution, on a system with
    !! several constraints.
    subroutine newton_matrix(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage), target :: sys
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: status
        real(wp) :: q(6), p(6)
        real(wp), allocatable :: x(:), y(:), jac(:, :), product(:)
        integer :: i
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call scheme%init(4, 3, 5, sys%n, sys%m, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
        if (allocated(error)) return
        call scheme%set_step(sys, q, p, 0.25_wp)
        allocate (x(scheme%nx), y(scheme%nx), jac(scheme%nx, scheme%nx), product(scheme%nx))
        do i = 1, scheme%nx
            x(i) = 1.0e-2_wp * sin(real(i, wp))
            y(i) = cos(real(3 * i, wp))
        end do
        call scheme%tangent(q, p, product(1:6), product(7:12), status)
        call check_status_code(error, status%code, HOLOSYM_NOT_INITIALIZED, "tangent first")
        if (allocated(error)) return
        call scheme%linearise(x, status)
        if (status%ok()) call scheme%jacobian(x, jac, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "linearise, jacobian")
        if (allocated(error)) return
        call scheme%linearised_product(y, product)
        call check(error, maxval(abs(product - matmul(jac, y))) <= &
            1.0e3_wp * eps * maxval(abs(matmul(abs(jac), abs(y)))), "derivative vs matrix: " &
            // real_str(maxval(abs(product - matmul(jac, y)))))
    end subroutine newton_matrix

    !> The tangent map against fourth-order central differences of the step map along
    !! tangent directions (the start-state check loosened to 1e-6 so that the perturbed states,
    !! off the manifold by the step squared, are taken), on both systems and both paths.
    subroutine differences(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        logical :: structured
        integer :: path
        sphere = spherical_pendulum()
        linkage = spring_linkage()
        do path = 1, 2
            structured = path == 1
            call check_differences(error, sphere, structured, 8, 7, 9, 0.125_wp)
            if (allocated(error)) return
            call check_differences(error, linkage, structured, 4, 3, 5, 0.25_wp)
            if (allocated(error)) return
        end do
    end subroutine differences

    subroutine check_differences(error, sys, structured, order_m, order_n, gauss_points, h)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        logical, intent(in) :: structured
        integer, intent(in) :: order_m, order_n, gauss_points
        real(wp), intent(in) :: h
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(sys%n), p(sys%n), dq(sys%n, 2 * sys%n), dp(sys%n, 2 * sys%n)
        real(wp) :: qb(sys%n), pb(sys%n), fq(sys%n), fp(sys%n), scale
        real(wp), parameter :: weights(4) = [8, -8, -1, 1] / 12.0_wp
        real(wp), parameter :: shifts(4) = [1, -1, 2, -2]
        integer :: k, j
        call paper_start(sys, q, p)
        call basis_of(sys, q, p, dq, dp)
        integ%structured = structured
        integ%manifold_tolerance = 1.0e-6_wp
        call integ%init(sys, order_m, order_n, gauss_points, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
        if (allocated(error)) return
        do k = 1, 2 * (sys%n - sys%m)
            fq = 0
            fp = 0
            do j = 1, 4
                qb = q + shifts(j) * difference_step * dq(:, k)
                pb = p + shifts(j) * difference_step * dp(:, k)
                call integ%step(sys, qb, pb, h, status=status)
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, "perturbed step")
                if (allocated(error)) return
                fq = fq + weights(j) * qb / difference_step
                fp = fp + weights(j) * pb / difference_step
            end do
            qb = q
            pb = p
            call integ%step_tangent(sys, qb, pb, h, dq(:, k:k), dp(:, k:k), status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step_tangent")
            if (allocated(error)) return
            scale = max(maxval(abs(fq)), maxval(abs(fp)))
            call check(error, maxval(abs(fq - dq(:, k))) <= difference_tolerance * scale .and. &
                maxval(abs(fp - dp(:, k))) <= difference_tolerance * scale, "n = " // &
                int_str(sys%n) // ", structured " // merge("T", "F", structured) // &
                ", direction " // int_str(k) // ": differences " // &
                real_str(max(maxval(abs(fq - dq(:, k))), maxval(abs(fp - dp(:, k))))))
            if (allocated(error)) return
        end do
    end subroutine check_differences

    !> A basis of the tangent space carried over 40 steps keeps its symplectic products
    !! omega(u_a, u_b) = u_a,q . u_b,p - u_a,p . u_b,q to round-off and stays tangent.
    subroutine symplectic(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        sphere = spherical_pendulum()
        linkage = spring_linkage()
        call check_symplectic(error, sphere, 8, 7, 9, 0.125_wp, 40)
        if (allocated(error)) return
        call check_symplectic(error, linkage, 4, 3, 5, 0.25_wp, 40)
    end subroutine symplectic

    subroutine check_symplectic(error, sys, order_m, order_n, gauss_points, h, steps)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        integer, intent(in) :: order_m, order_n, gauss_points, steps
        real(wp), intent(in) :: h
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(sys%n), p(sys%n), dq(sys%n, 2 * sys%n), dp(sys%n, 2 * sys%n)
        real(wp), allocatable :: start_form(:, :), form(:, :)
        real(wp) :: drift, residual, size_now
        integer :: k, count, step
        count = 2 * (sys%n - sys%m)
        call paper_start(sys, q, p)
        call basis_of(sys, q, p, dq, dp)
        call check(error, all(norm2(dq(:, 1:count), 1)**2 + norm2(dp(:, 1:count), 1)**2 > &
            0.5_wp), "a basis of " // int_str(count) // " tangent vectors")
        if (allocated(error)) return
        start_form = symplectic_form(dq(:, 1:count), dp(:, 1:count))
        call integ%init(sys, order_m, order_n, gauss_points, status)
        drift = 0
        residual = 0
        size_now = 1
        do step = 1, steps
            if (status%ok()) call integ%step_tangent(sys, q, p, h, dq(:, 1:count), &
                                                     dp(:, 1:count), status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step " // int_str(step))
            if (allocated(error)) return
            form = symplectic_form(dq(:, 1:count), dp(:, 1:count))
            size_now = max(maxval(abs(dq(:, 1:count))), maxval(abs(dp(:, 1:count))))
            drift = max(drift, maxval(abs(form - start_form)) / max(1.0_wp, size_now**2))
            do k = 1, count
                residual = max(residual, tangent_residual(sys, q, p, dq(:, k), dp(:, k)))
            end do
        end do
        call check(error, drift <= symplectic_tolerance, "n = " // int_str(sys%n) // &
            ": |S^T J S - J| = " // real_str(drift) // " (vectors grew to " // &
            real_str(size_now) // ")")
        if (allocated(error)) return
        call check(error, residual <= tangent_tolerance, "images off the tangent space: " // &
            real_str(residual))
    end subroutine check_symplectic

    !> The reduced step and the general step give the same tangent map (the reduced step's
    !! solution read off its dense output solves the general equations).
    subroutine both_paths(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage), target :: sys
        type(constrained_integrator) :: integ(2)
        type(holosym_status_t) :: status
        real(wp) :: q(6, 2), p(6, 2), dq(6, 12, 2), dp(6, 12, 2)
        integer :: path, step
        sys = spring_linkage()
        do path = 1, 2
            call paper_start(sys, q(:, path), p(:, path))
            call basis_of(sys, q(:, path), p(:, path), dq(:, :, path), dp(:, :, path))
            integ(path)%structured = path == 1
            call integ(path)%init(sys, 4, 3, 5, status)
            do step = 1, 5
                if (status%ok()) call integ(path)%step_tangent(sys, q(:, path), p(:, path), &
                    0.25_wp, dq(:, 1:6, path), dp(:, 1:6, path), status=status)
            end do
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "path " // int_str(path))
            if (allocated(error)) return
        end do
        call check(error, maxval(abs(dq(:, 1:6, 1) - dq(:, 1:6, 2))) <= 1.0e4_wp * eps .and. &
            maxval(abs(dp(:, 1:6, 1) - dp(:, 1:6, 2))) <= 1.0e4_wp * eps, "paths differ by " // &
            real_str(max(maxval(abs(dq(:, 1:6, 1) - dq(:, 1:6, 2))), &
                         maxval(abs(dp(:, 1:6, 1) - dp(:, 1:6, 2))))))
    end subroutine both_paths

    !> project_tangent leaves a tangent vector and moves a generic one onto the tangent
    !! space (residual of order 1 before, round-off after); a second projection changes
    !! nothing beyond round-off.
    subroutine projection(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(holosym_status_t) :: status
        real(wp) :: q(6), p(6), dq(6, 1), dp(6, 1), once_q(6, 1), once_p(6, 1)
        integer :: i
        sys = spring_linkage()
        call paper_start(sys, q, p)
        dq(:, 1) = [(cos(real(i, wp)), i = 1, 6)]
        dp(:, 1) = [(sin(real(2 * i, wp)), i = 1, 6)]
        call check(error, tangent_residual(sys, q, p, dq(:, 1), dp(:, 1)) > 1.0e-3_wp, &
            "a generic vector has a residual of order 1")
        if (allocated(error)) return
        call project_tangent(sys, q, p, dq, dp, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "project_tangent")
        if (allocated(error)) return
        call check(error, tangent_residual(sys, q, p, dq(:, 1), dp(:, 1)) <= 64 * eps, &
            "residual after projection " // real_str(tangent_residual(sys, q, p, dq(:, 1), &
            dp(:, 1))))
        if (allocated(error)) return
        once_q = dq
        once_p = dp
        call project_tangent(sys, q, p, dq, dp, status)
        call check(error, maxval(abs(dq - once_q)) + maxval(abs(dp - once_p)) <= 64 * eps, &
            "a second projection moved the vector")
        if (allocated(error)) return
        call project_tangent(sys, q, p, dq(1:5, :), dp, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "5 rows")
    end subroutine projection

    !> Vectors off the tangent space, of the wrong shape or not finite are refused before
    !! the step, with q, p, dq and dp unchanged; a zero vector maps to zero.
    subroutine refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q0(3), p0(3), dq(3, 2), dp(3, 2), dq0(3, 2), dp0(3, 2)
        sys = spherical_pendulum()
        call paper_start(sys, q, p)
        q0 = q
        p0 = p
        call basis_of(sys, q, p, dq, dp)
        dq(:, 2) = q
        dq0 = dq
        dp0 = dp
        call integ%init(sys, 4, 3, 5, status)
        call integ%step_tangent(sys, q, p, 0.125_wp, dq, dp, status=status)
        call check_status_code(error, status%code, HOLOSYM_OFF_MANIFOLD, "radial vector")
        if (allocated(error)) return
        call check(error, index(status%message, "tangent vector 2") > 0 .and. &
            index(status%message, "project_tangent") > 0, "message: " // status%message)
        if (allocated(error)) return
        call check(error, all(q == q0) .and. all(p == p0) .and. all(dq == dq0) .and. &
            all(dp == dp0), "state or vectors changed by a refused call")
        if (allocated(error)) return
        call integ%step_tangent(sys, q, p, 0.125_wp, dq(1:2, :), dp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "2 x 2 and 3 x 2")
        if (allocated(error)) return
        dq(1, 2) = ieee_value(1.0_wp, ieee_positive_inf)
        call integ%step_tangent(sys, q, p, 0.125_wp, dq, dp, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "infinite entry")
        if (allocated(error)) return
        dq(:, 2) = 0
        dp(:, 2) = 0
        call integ%step_tangent(sys, q, p, 0.125_wp, dq, dp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "zero vector")
        if (allocated(error)) return
        call check(error, all(dq(:, 2) == 0) .and. all(dp(:, 2) == 0), "zero maps to zero")
    end subroutine refusals

    !> The first columns of an orthonormal basis of the tangent space at (q, p)
    !! (`tangent_basis`), as many as dq has (the columns beyond 2(n - m) zero).
    subroutine basis_of(sys, q, p, dq, dp)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: dq(:, :), dp(:, :)
        real(wp) :: bq(sys%n, 2 * sys%n), bp(sys%n, 2 * sys%n)
        integer :: count, k
        call tangent_basis(sys, q, p, bq, bp, count)
        k = min(size(dq, 2), size(bq, 2))
        dq = 0
        dp = 0
        dq(:, 1:k) = bq(:, 1:k)
        dp(:, 1:k) = bp(:, 1:k)
    end subroutine basis_of

    !> omega(u_a, u_b) for the columns of (dq, dp).
    pure function symplectic_form(dq, dp) result(form)
        real(wp), intent(in) :: dq(:, :), dp(:, :)
        real(wp) :: form(size(dq, 2), size(dq, 2))
        form = matmul(transpose(dq), dp) - matmul(transpose(dp), dq)
    end function symplectic_form

end module test_tangent
