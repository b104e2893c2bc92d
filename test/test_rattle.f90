!> Tests of the competitor inside holosym: RATTLE and its symmetric compositions
!! (coefficients and their order conditions, orders 2-10 observed, constraints at
!! round-off, general = separable path).
module test_rattle
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NOT_INITIALIZED
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_manifold, only: manifold_residuals
    use holosym_models, only: spherical_pendulum, spring_linkage
    use holosym_rattle, only: rattle_integrator, composition_coefficients
    use holosym_compositions, only: composition_order_residuals, published_coefficients, &
        composition_families, composition_orders
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: rattle_tests

    !> Constraint residuals after every step (1e-30 in real128, 1e4 epsilon in real64).
    real(wp), parameter :: constraint_bound = max(1.0e-30_wp, 1.0e4_wp * epsilon(1.0_wp))
    !> Allowed deviation of a measured order.
    real(wp), parameter :: order_slack = 0.3_wp
    !> Time span of the order runs.
    real(wp), parameter :: order_span = 2

contains

    !> The tests of this suite.
    function rattle_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("coefficients_sum_symmetric", coefficients), &
            new_test("invalid_order_and_family", invalid_arguments), &
            new_test("constraints_each_step_pendulum", constraints_pendulum), &
            new_test("constraints_each_step_linkage", constraints_linkage), &
            new_test("general_equals_separable", general_equals_separable), &
            new_test("order_2_4_6_triple_jump", orders_triple_jump), &
            new_test("order_4_6_8_suzuki", orders_suzuki), &
            new_test("order_conditions_closed_forms", conditions_closed_forms), &
            new_test("order_conditions_published_refined", conditions_published), &
            new_test("order_6_8_10_gni_compositions", orders_gni) &
        ]
    end function rattle_tests

    subroutine coefficients(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp), allocatable :: gammas(:)
        type(holosym_status_t) :: status
        integer :: f, o, k
        integer, allocatable :: orders(:)
        do f = 1, size(composition_families)
            orders = composition_orders(trim(composition_families(f)))
            call check(error, size(orders) > 0, "no orders for " // composition_families(f))
            do o = 1, size(orders)
                call composition_coefficients(orders(o), trim(composition_families(f)), &
                                              gammas, status)
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, &
                    trim(composition_families(f)) // " order " // int_str(orders(o)))
                if (allocated(error)) return
                call check(error, abs(sum(gammas) - 1) <= 100 * epsilon(1.0_wp), &
                    trim(composition_families(f)) // ": fractions sum to " // &
                    real_str(sum(gammas)))
                do k = 1, size(gammas)
                    call check(error, gammas(k) == gammas(size(gammas) + 1 - k), &
                        trim(composition_families(f)) // ": composition not symmetric")
                end do
                if (allocated(error)) return
            end do
        end do
        ! Stage counts: 3^(p/2-1), 5^(p/2-1) and the published ones.
        call composition_coefficients(10, "triple-jump", gammas, status)
        call check(error, size(gammas) == 81, "triple-jump 10: " // int_str(size(gammas)))
        call composition_coefficients(10, "suzuki", gammas, status)
        call check(error, size(gammas) == 625, "suzuki 10: " // int_str(size(gammas)))
        call composition_coefficients(8, "suzuki-umeno", gammas, status)
        call check(error, size(gammas) == 15, "suzuki-umeno 8: " // int_str(size(gammas)))
        call composition_coefficients(8, "kahan-li", gammas, status)
        call check(error, size(gammas) == 17, "kahan-li 8: " // int_str(size(gammas)))
        call composition_coefficients(10, "hlw", gammas, status)
        call check(error, size(gammas) == 33, "hlw 10: " // int_str(size(gammas)))
        call composition_coefficients(10, "sofroniou-spaletta", gammas, status)
        call check(error, size(gammas) == 33, "sofroniou-spaletta 10: " // int_str(size(gammas)))
    end subroutine coefficients

    !> The order conditions hold to round-off for the closed-form compositions of each
    !! order, and fail for the next order (they test what they claim), with the counts
    !! 1, 2, 4, 8, 16 of conditions.
    subroutine conditions_closed_forms(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp), allocatable :: gammas(:), residuals(:)
        type(holosym_status_t) :: status
        integer, parameter :: counts(5) = [1, 2, 4, 8, 16]
        integer :: order, f
        character(len=11) :: family
        do f = 1, 2
            family = merge("triple-jump", "suzuki     ", f == 1)
            do order = 2, 10, 2
                call composition_coefficients(order, trim(family), gammas, status)
                residuals = composition_order_residuals(gammas, order)
                call check(error, size(residuals) == counts(order / 2), "order " // &
                    int_str(order) // ": " // int_str(size(residuals)) // " conditions")
                call check(error, maxval(abs(residuals)) <= 1.0e6_wp * epsilon(1.0_wp), &
                    trim(family) // " order " // int_str(order) // ": residual " // &
                    real_str(maxval(abs(residuals))))
                ! The next order's residuals are small for Suzuki's: only real128 tells.
                if (order < 10 .and. epsilon(1.0_wp) < 1.0e-20_wp) then
                    residuals = composition_order_residuals(gammas, order + 2)
                    call check(error, maxval(abs(residuals)) > 1.0e-12_wp, trim(family) // &
                        " order " // int_str(order) // " passes the conditions of order " // &
                        int_str(order + 2))
                end if
                if (allocated(error)) return
            end do
        end do
    end subroutine conditions_closed_forms

    !> The published digits satisfy the order conditions to their own accuracy (about
    !! 1e-26); the refined coefficients to round-off (a few 1e-33 in real128).
    subroutine conditions_published(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=18), parameter :: families(6) = [character(len=18) :: "yoshida", &
            "kahan-li", "kahan-li", "suzuki-umeno", "hlw", "sofroniou-spaletta"]
        integer, parameter :: orders(6) = [6, 6, 8, 8, 10, 10]
        real(wp), allocatable :: gammas(:), half(:), residuals(:)
        type(holosym_status_t) :: status
        real(wp) :: published, refined, change
        integer :: f, k, s
        do f = 1, size(families)
            half = published_coefficients(orders(f), trim(families(f)))
            s = 2 * size(half) - 1
            allocate (gammas(s))
            do k = 1, s
                gammas(k) = half(min(k, s + 1 - k))
            end do
            published = maxval(abs(composition_order_residuals(gammas, orders(f))))
            deallocate (gammas)
            call composition_coefficients(orders(f), trim(families(f)), gammas, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, families(f))
            if (allocated(error)) return
            residuals = composition_order_residuals(gammas, orders(f))
            refined = maxval(abs(residuals))
            change = maxval(abs(gammas(1:size(half)) - half))
            call check(error, published <= max(1.0e-24_wp, 1.0e3_wp * epsilon(1.0_wp)), &
                trim(families(f)) // ": published digits miss the conditions by " // &
                real_str(published))
            call check(error, refined <= 64 * epsilon(1.0_wp), trim(families(f)) // &
                ": refined coefficients miss the conditions by " // real_str(refined))
            call check(error, change <= max(1.0e-24_wp, 1.0e3_wp * epsilon(1.0_wp)), &
                trim(families(f)) // ": refinement moved the coefficients by " // &
                real_str(change))
            if (allocated(error)) return
            deallocate (gammas)
        end do
    end subroutine conditions_published

    subroutine invalid_arguments(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(rattle_integrator) :: rattle
        type(spherical_pendulum) :: sys
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call rattle%step(sys, q, p, 0.1_wp, status)
        call check_status_code(error, status%code, HOLOSYM_NOT_INITIALIZED, "step before init")
        call rattle%init(sys, 5, "suzuki", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, "odd order")
        call rattle%init(sys, 12, "suzuki", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, "order 12")
        call rattle%init(sys, 4, "yoshida", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, "yoshida order 4")
        call check(error, index(status%message, "6") > 0, "message names the orders")
        call rattle%init(sys, 4, "verlet", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "unknown family")
        call check(error, index(status%message, "verlet") > 0, "message names the family")
    end subroutine invalid_arguments

    !> Run `steps` steps, checking both constraint levels after each.
    subroutine constraints_after_steps(error, sys, q, p, order, separable, h, steps, name)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(inout) :: q(:), p(:)
        integer, intent(in) :: order, steps
        logical, intent(in) :: separable
        real(wp), intent(in) :: h
        character(len=*), intent(in) :: name
        type(rattle_integrator) :: rattle
        type(holosym_status_t) :: status
        real(wp) :: position, velocity, worst_position, worst_velocity
        integer :: k
        call rattle%init(sys, order, "triple-jump", status)
        rattle%separable = separable
        worst_position = 0
        worst_velocity = 0
        do k = 1, steps
            call rattle%step(sys, q, p, h, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, name // " step")
            if (allocated(error)) return
            call manifold_residuals(sys, q, p, position, velocity)
            worst_position = max(worst_position, position)
            worst_velocity = max(worst_velocity, velocity)
        end do
        call check(error, worst_position <= constraint_bound, name // ": max |phi| = " // &
            real_str(worst_position))
        call check(error, worst_velocity <= constraint_bound, name // ": max |Phi H_p| = " // &
            real_str(worst_velocity))
    end subroutine constraints_after_steps

    subroutine constraints_pendulum(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call constraints_after_steps(error, sys, q, p, 4, .true., 0.1_wp, 20, "pendulum")
        call sys%initial_state(q, p)
        call constraints_after_steps(error, sys, q, p, 4, .false., 0.1_wp, 20, &
                                     "pendulum (general)")
    end subroutine constraints_pendulum

    subroutine constraints_linkage(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        real(wp) :: q(6), p(6)
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call constraints_after_steps(error, sys, q, p, 6, .true., 0.2_wp, 10, "linkage")
        call sys%initial_state(q, p)
        call constraints_after_steps(error, sys, q, p, 2, .false., 0.2_wp, 10, &
                                     "linkage (general)")
    end subroutine constraints_linkage

    !> The general (Lobatto IIIA-IIIB) path solves the same equations as the separable one.
    subroutine general_equals_separable(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(rattle_integrator) :: fast, general
        type(holosym_status_t) :: status
        real(wp) :: qs(6), ps(6), qg(6), pg(6), difference
        sys = spring_linkage()
        call sys%initial_state(qs, ps)
        qg = qs
        pg = ps
        call fast%init(sys, 4, "suzuki", status)
        fast%separable = .true.
        call general%init(sys, 4, "suzuki", status)
        call fast%integrate(sys, qs, ps, 0.25_wp, 8, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "separable")
        call general%integrate(sys, qg, pg, 0.25_wp, 8, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "general")
        if (allocated(error)) return
        difference = max(maxval(abs(qs - qg)), maxval(abs(ps - pg)))
        call check(error, difference <= constraint_bound, "paths differ by " // &
            real_str(difference))
    end subroutine general_equals_separable

    !> Global error order of RATTLE composed to `order` on the spherical pendulum, from
    !! two step sizes, against holosym (M = 8, order 16) at a small step.
    subroutine check_order(error, order, family, h)
        type(test_error_t), allocatable, intent(inout) :: error
        integer, intent(in) :: order
        character(len=*), intent(in) :: family
        real(wp), intent(in) :: h
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: reference
        type(rattle_integrator) :: rattle
        type(holosym_status_t) :: status
        real(wp) :: q_ref(3), p_ref(3), q(3), p(3), errors(2), measured
        integer :: level, steps
        sys = spherical_pendulum()
        call sys%initial_state(q_ref, p_ref)
        call reference%init(sys, 8, 7, 9, status)
        reference%newton%simplified = .true.
        reference%linear_solver = "mixed"
        call reference%integrate(sys, q_ref, p_ref, 0.125_wp, nint(order_span / 0.125_wp), &
                                 status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "reference")
        do level = 1, 2
            call sys%initial_state(q, p)
            call rattle%init(sys, order, family, status)
            rattle%separable = .true.
            steps = nint(order_span / h) * level
            call rattle%integrate(sys, q, p, order_span / steps, steps, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, family)
            if (allocated(error)) return
            errors(level) = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
        end do
        measured = log(errors(1) / errors(2)) / log(2.0_wp)
        call check(error, abs(measured - order) <= order_slack, family // " order " // &
            int_str(order) // ": measured " // real_str(measured) // " (errors " // &
            real_str(errors(1)) // ", " // real_str(errors(2)) // ")")
    end subroutine check_order

    subroutine orders_triple_jump(error)
        type(test_error_t), allocatable, intent(out) :: error
        if (epsilon(1.0_wp) > 1.0e-20_wp) return  ! errors would sink into real64 round-off
        call check_order(error, 2, "triple-jump", 0.05_wp)
        call check_order(error, 4, "triple-jump", 0.1_wp)
        call check_order(error, 6, "triple-jump", 0.2_wp)
    end subroutine orders_triple_jump

    subroutine orders_suzuki(error)
        type(test_error_t), allocatable, intent(out) :: error
        if (epsilon(1.0_wp) > 1.0e-20_wp) return  ! errors would sink into real64 round-off
        call check_order(error, 4, "suzuki", 0.2_wp)
        call check_order(error, 6, "suzuki", 0.25_wp)
        call check_order(error, 8, "suzuki", 0.5_wp)
    end subroutine orders_suzuki

    subroutine orders_gni(error)
        type(test_error_t), allocatable, intent(out) :: error
        if (epsilon(1.0_wp) > 1.0e-20_wp) return  ! errors would sink into real64 round-off
        call check_order(error, 6, "yoshida", 0.25_wp)
        call check_order(error, 6, "kahan-li", 0.25_wp)
        call check_order(error, 8, "kahan-li", 0.5_wp)
        call check_order(error, 8, "suzuki-umeno", 0.5_wp)
        call check_order(error, 10, "hlw", 0.5_wp)
        call check_order(error, 10, "sofroniou-spaletta", 0.5_wp)
    end subroutine orders_gni

end module test_rattle
