!> Tests of the projection of a step's end state onto the constraints
!! (`project_end_state`, `project_sparse`): at a loose Newton tolerance the end states of
!! every step satisfy phi = 0 and Phi H_p = 0 to round-off on the reduced step (dense and
!! banded systems) and on the general step, where without the projection they miss by the
!! Newton error; the projection leaves the trajectory within that error; the banded solve
!! solves the Gram system; a failing projection leaves the state as it was.
module test_projection
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, &
        HOLOSYM_NONFINITE_VALUE
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_residuals, gram_band, band_cholesky, &
        band_cholesky_solve
    use holosym_projection, only: project_sparse
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_model_chain, only: pendulum_chain
    use holosym_test_systems, only: builtin_system, paper_start, uneven_chain
    use holosym_test_commands, only: command_result_t, run_holosym
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: projection_tests

    !> Records the largest residuals of the end states a run passes through.
    type, extends(step_observer) :: residual_recorder
        class(constrained_hamiltonian), pointer :: sys => null()
        real(wp) :: position = 0   !! max |phi| over the end states
        real(wp) :: velocity = 0   !! max |Phi H_p| over the end states
    contains
        procedure :: observe => record_residuals
    end type residual_recorder

contains

    !> The tests of this suite.
    function projection_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("end_states_on_the_constraints_at_a_loose_tolerance", loose_tolerance), &
            new_test("banded_gram_solve", banded_solve), &
            new_test("sparse_projection_of_a_nearby_state", nearby_state), &
            new_test("failed_projection_keeps_the_state", failed_projection), &
            new_test("cli_reports_the_step_ends", cli_step_ends) &
        ]
    end function projection_tests

    subroutine record_residuals(self, step, t, q, p, info, halt)
        class(residual_recorder), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        real(wp) :: position, velocity
        call manifold_residuals(self%sys, q, p, position, velocity)
        self%position = max(self%position, position)
        self%velocity = max(self%velocity, velocity)
    end subroutine record_residuals

    !> The round-off bound of the end states' residuals: 64 epsilon (the constraints of
    !! these systems have terms of size up to about 10).
    pure real(wp) function round_off()
        round_off = 64 * epsilon(1.0_wp)
    end function round_off

    !> Newton tolerance 1e-12 (real64: 1e-5), 40 steps of (6, 5, 7) at h = 1/4: the
    !! spherical pendulum and a chain of four unequal links on the reduced step, the
    !! spring-linkage on the general step (`structured = .false.`). With
    !! `project_end_state` (the default) every end state is on the constraints to
    !! round-off; without it they miss by more than a hundred times that; the two runs'
    !! end states differ by at most 1e3 times the tolerance (Newton errors over 40 steps).
    subroutine loose_tolerance(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(3) = [character(len=8) :: "pendulum", &
            "chain", "linkage"]
        real(wp) :: tolerance, with(2), without(2), distance
        integer :: k
        tolerance = merge(1.0e-5_wp, 1.0e-12_wp, wp_is_double)
        do k = 1, size(names)
            call loose_run(error, trim(names(k)), tolerance, .true., with, distance)
            if (allocated(error)) return
            call loose_run(error, trim(names(k)), tolerance, .false., without, distance)
            if (allocated(error)) return
            call check(error, maxval(with) <= round_off(), trim(names(k)) // &
                ": projected end states max |phi| " // real_str(with(1)) // &
                ", max |Phi H_p| " // real_str(with(2)))
            call check(error, maxval(without) > 100 * round_off(), trim(names(k)) // &
                ": without the projection max |phi| " // real_str(without(1)) // &
                ", max |Phi H_p| " // real_str(without(2)) // " (expected the Newton error)")
            call check(error, distance <= 1000 * tolerance, trim(names(k)) // &
                ": the projection moved the end state by " // real_str(distance))
            if (allocated(error)) return
        end do
    end subroutine loose_tolerance

    !> One run of `loose_tolerance`: its largest end-state residuals in `residuals`, and
    !! in `distance` max |q - q'|, |p - p'| at its end against the other setting's run.
    subroutine loose_run(error, name, tolerance, project, residuals, distance)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: name
        real(wp), intent(in) :: tolerance
        logical, intent(in) :: project
        real(wp), intent(out) :: residuals(2), distance
        class(constrained_hamiltonian), allocatable, target :: sys
        real(wp), allocatable :: q(:), p(:), q_other(:), p_other(:)
        type(constrained_integrator) :: integ
        type(residual_recorder) :: recorder
        type(holosym_status_t) :: status
        type(pendulum_chain) :: chain
        real(wp) :: qc(8), pc(8)
        if (name == "chain") then
            call uneven_chain(chain, qc, pc)
            allocate (sys, source=chain)
            q = qc
            p = pc
        else
            call builtin_system(name, sys, q, p)
            call paper_start(sys, q, p)
        end if
        integ%structured = name /= "linkage"
        call integ%init(sys, 6, 5, 7, status)
        call check(error, status%ok(), name // ": init: " // status%message)
        if (allocated(error)) return
        integ%newton%tolerance = tolerance
        integ%project_end_state = project
        recorder%sys => sys
        q_other = q
        p_other = p
        call integ%integrate(sys, q, p, 0.25_wp, 40, observer=recorder, status=status)
        call check(error, status%ok(), name // ": integrate: " // status%message)
        if (allocated(error)) return
        residuals = [recorder%position, recorder%velocity]
        ! The same run with the other setting, to compare end states.
        call integ%init(sys, 6, 5, 7, status)
        integ%newton%tolerance = tolerance
        integ%project_end_state = .not. project
        call integ%integrate(sys, q_other, p_other, 0.25_wp, 40, status=status)
        call check(error, status%ok(), name // ": second run: " // status%message)
        if (allocated(error)) return
        distance = max(maxval(abs(q - q_other)), maxval(abs(p - p_other)))
    end subroutine loose_run

    !> `band_cholesky_solve` solves G y = x for the Gram matrix Phi W Phi^T of a chain of
    !! eight links (banded, unequal weights), checked against G formed densely.
    subroutine banded_solve(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: chain
        real(wp), allocatable :: q(:), p(:), values(:), band(:, :), dense(:, :), jac(:, :)
        integer, allocatable :: rows(:), columns(:), order(:)
        real(wp) :: x(8), y(8), weights(16)
        integer :: e, failed, l
        chain = pendulum_chain(8)
        allocate (q(16), p(16), jac(8, 16))
        call chain%state_from_angles([(0.1_wp * l, l = 1, 8)], [(0.0_wp, l = 1, 8)], q, p)
        call chain%constraint_jacobian(q, jac)
        call chain%constraint_sparsity(rows, columns)
        values = [(jac(rows(e), columns(e)), e = 1, size(rows))]
        weights = [(1.0_wp + 0.25_wp * mod(e, 3), e = 1, 16)]
        order = [(9 - l, l = 1, 8)]   ! reversed: the band is symmetric in the order
        call gram_band(16, 8, rows, columns, order, values, band, weights)
        call check(error, size(band, 1) == 2, "band of width " // int_str(size(band, 1) - 1) &
            // ", expected 1 (neighbouring links share a bob)")
        call band_cholesky(band, 8 * epsilon(1.0_wp), failed)
        call check(error, failed == 0, "factorisation failed at pivot " // int_str(failed))
        if (allocated(error)) return
        x = [(real(l, wp) / 3, l = 1, 8)]
        y = x
        call band_cholesky_solve(band, order, y)
        dense = matmul(jac, matmul(diagonal(weights), transpose(jac)))
        call check(error, maxval(abs(matmul(dense, y) - x)) <= 100 * epsilon(1.0_wp), &
            "|G y - x| = " // real_str(maxval(abs(matmul(dense, y) - x))))
    end subroutine banded_solve

    pure function diagonal(v) result(d)
        real(wp), intent(in) :: v(:)
        real(wp) :: d(size(v), size(v))
        integer :: i
        d = 0
        do i = 1, size(v)
            d(i, i) = v(i)
        end do
    end function diagonal

    !> A state of the uneven chain moved off the constraints by 1e-6 (real64: 1e-4) in q
    !! and p: `project_sparse` puts it back to round-off, moving it by about that much,
    !! and the position shift is along M^-1 Phi^T (its mass-weighted part has no
    !! component tangent to the constraints).
    subroutine nearby_state(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: chain
        type(holosym_status_t) :: status
        real(wp) :: q(8), p(8), q0(8), p0(8), jac(4, 8), position, velocity, offset
        real(wp) :: tangent(8), inverse_mass(8), hp(8)
        integer, allocatable :: rows(:), columns(:)
        integer :: e
        call uneven_chain(chain, q0, p0)
        offset = merge(1.0e-4_wp, 1.0e-6_wp, wp_is_double)
        q = q0 + offset * [(sin(real(e, wp)), e = 1, 8)]
        p = p0 + offset * [(cos(real(e, wp)), e = 1, 8)]
        call chain%constraint_sparsity(rows, columns)
        ! H = sum |p_c|^2 / (2 m_c) + U: H_p of a unit momentum is the inverse mass.
        do e = 1, 8
            tangent = 0
            tangent(e) = 1
            call chain%dh_dp(q0, tangent, hp)
            inverse_mass(e) = hp(e)
        end do
        q0 = q
        p0 = p
        call project_sparse(chain, rows, columns, [1, 2, 3, 4], inverse_mass, q, p, &
                            position, velocity, status)
        call check(error, status%ok(), "project_sparse: " // status%message)
        if (allocated(error)) return
        call manifold_residuals(chain, q, p, position, velocity)
        call check(error, max(position, velocity) <= round_off(), "after: max |phi| " // &
            real_str(position) // ", max |Phi H_p| " // real_str(velocity))
        call check(error, maxval(abs(q - q0)) <= 100 * offset .and. &
            maxval(abs(p - p0)) <= 100 * offset, "moved by " // &
            real_str(maxval(abs(q - q0))) // " and " // real_str(maxval(abs(p - p0))))
        ! M (q - q0) = Phi^T mu: orthogonal to every tangent direction t (Phi t = 0).
        call chain%constraint_jacobian(q, jac)
        ! The whole chain turned about the pivot's neighbour: the first link rotates, the
        ! other bobs move with the first one (their links keep their lengths).
        tangent(1:2) = [-jac(1, 2), jac(1, 1)]
        do e = 3, 7, 2
            tangent(e:e + 1) = tangent(1:2)
        end do
        call check(error, maxval(abs(matmul(jac, tangent))) <= 100 * epsilon(1.0_wp), &
            "the test's tangent direction is not tangent")
        call check(error, abs(sum((q - q0) / inverse_mass * tangent)) <= &
            100 * offset**2 + 100 * epsilon(1.0_wp), "the shift has a tangent part " // &
            real_str(abs(sum((q - q0) / inverse_mass * tangent))))
    end subroutine nearby_state

    !> A NaN coordinate makes the projection fail with HOLOSYM_NONFINITE_VALUE and leaves
    !! q and p as they were.
    subroutine failed_projection(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: chain
        type(holosym_status_t) :: status
        real(wp) :: q(8), p(8), q0(8), p0(8), position, velocity
        integer, allocatable :: rows(:), columns(:)
        integer :: c
        call uneven_chain(chain, q, p)
        q(3) = ieee_value(q(3), ieee_quiet_nan)
        q0 = q
        p0 = p
        call chain%constraint_sparsity(rows, columns)
        call project_sparse(chain, rows, columns, [1, 2, 3, 4], [(1.0_wp, c = 1, 8)], q, p, &
                            position, velocity, status)
        call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, "project_sparse")
        call check(error, all(p == p0) .and. all(q(1:2) == q0(1:2)) .and. &
            all(q(4:) == q0(4:)) .and. q(3) /= q(3), "the state changed")
    end subroutine failed_projection

    !> `holosym simulate --accuracy 1e-10` (a loose Newton tolerance) reports max |phi|
    !! at the step ends at round-off, and over the nodes the Newton error (real128).
    subroutine cli_step_ends(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: run
        real(wp) :: ends, nodes
        integer :: i, at, ios
        call run_holosym("simulate --system pendulum --accuracy 1e-10 --T 10 --every 1000", &
                         run)
        call check(error, run%exit_code == 0, "exit " // int_str(run%exit_code))
        if (allocated(error)) return
        ends = -1
        nodes = -1
        do i = 1, size(run%err)
            at = index(run%err(i)%text, "max |phi| ")
            if (at == 0) cycle
            read (run%err(i)%text(at + 10:), *, iostat=ios) ends
            at = index(run%err(i)%text, "at the step ends (")
            if (at > 0) read (run%err(i)%text(at + 18:), *, iostat=ios) nodes
        end do
        call check(error, ends >= 0 .and. ends <= round_off(), "max |phi| at the step ends " &
            // real_str(ends))
        ! (In real64 the iteration at this request converges to round-off anyway.)
        call check(error, nodes > 1000 * round_off() .or. wp_is_double, &
            "max |phi| over the nodes " // real_str(nodes) // " (expected the Newton error)")
    end subroutine cli_step_ends

end module test_projection
