!> A user-defined system with holosym: the planar pendulum of `cartesian_pendulum_model`
!! released at rest from 1 rad. An observer stops `integrate` after each step in which the
!! bob crosses x = 0; `dense_output` of that step (the scheme's polynomials q~, p~,
!! lambda~) then locates the crossing time by bisection. Successive crossings are half a
!! period apart; the exact period is 4 K(sin(theta0/2)) sqrt(length/gravity).
!! The table shows dense output inside the last step: phi = 0 to round-off at the
!! displacement nodes (tau = 0, 0.276, 0.724, 1 for M = 3), O(h^(M+1)) between them.
!!
!! Run: `fpm run --example planar_pendulum`. Output:
!!
!!     Planar pendulum defined in this example, released at rest from 1 rad
!!     (M, N, G) = (3, 2, 4), h = 1/16
!!     crossing 1 of x = 0 at t =   1.674993916205702362
!!     crossing 2 of x = 0 at t =   5.024981748926269465
!!     crossing 3 of x = 0 at t =   8.374969580442052816
!!     crossing 4 of x = 0 at t =  11.724957411931389343
!!     period from the crossings:       6.699975663817124654
!!     exact period 4 K(sin(1/2)):      6.699975664370452713
!!     difference:                    -5.533E-10
!!     max |(H - H0)/H0|:              4.854E-12
!!     max |phi| at the nodes:         3.852E-34
!!     dense output within the last step, at the displacement nodes and between them:
!!          tau                  x~                  y~             lambda~  |q~|^2 - 1
!!      0.00000 -0.0358999669928086 -0.9993553884229150  0.9587305978394420   0.000E+00  (node)
!!      0.13820 -0.0276268684688895 -0.9996183329347336  0.9591251707988123   5.540E-08
!!      0.27639 -0.0193498144976819 -0.9998127748128173  0.9594169086994612  -9.630E-35  (node)
!!      0.50000 -0.0059519103249026 -0.9999822512852294  0.9596711271628206  -7.188E-08
!!      0.72361  0.0074482236928112 -0.9999722615972014  0.9596560790913251   0.000E+00  (node)
!!      0.86180  0.0157288856289122 -0.9998763211278625  0.9595121345865458   5.540E-08
!!      1.00000  0.0240072955676754 -0.9997117833453431  0.9592653238119245   1.926E-34  (node)
program example_planar_pendulum
    use holosym, only: wp, constrained_integrator, holosym_status_t, gauss_lobatto, &
        HOLOSYM_USER_ABORT
    use cartesian_pendulum_model, only: cartesian_pendulum, crossing_monitor
    implicit none
    !> Scheme (M, N, G) = (3, 2, 4), order 2M = 6, and the step size.
    integer, parameter :: order_m = 3, order_n = 2, gauss_points = 4
    real(wp), parameter :: h = 1.0_wp / 16
    !> Release angle [rad] and number of crossings of x = 0 to find.
    real(wp), parameter :: release_angle = 1.0_wp
    integer, parameter :: crossings = 4
    !> Step limit per search (a crossing comes at least every half period, ~30 steps).
    integer, parameter :: max_steps = 1000
    type(cartesian_pendulum) :: sys
    type(constrained_integrator) :: integrator
    type(crossing_monitor) :: monitor
    type(holosym_status_t) :: status
    real(wp) :: q(2), p(2), t, times(crossings), period, exact
    real(wp) :: nodes(order_m + 1), weights(order_m + 1)
    integer :: i, steps_done

    sys = cartesian_pendulum()
    q = sys%length * [sin(release_angle), -cos(release_angle)]
    p = 0
    call integrator%init(sys, order_m, order_n, gauss_points)
    monitor%sys = sys
    monitor%energy0 = sys%hamiltonian(q, p)
    monitor%previous_x = q(1)

    print '(a)', "Planar pendulum defined in this example, released at rest from 1 rad"
    print '(a, 3(i0, a))', "(M, N, G) = (", order_m, ", ", order_n, ", ", gauss_points, &
        "), h = 1/16"
    t = 0
    do i = 1, crossings
        call integrator%integrate(sys, q, p, h, max_steps, monitor, steps_done, status)
        if (status%code /= HOLOSYM_USER_ABORT) error stop "no crossing: " // status%message
        t = t + steps_done * h
        times(i) = t - h + crossing_tau() * h
        print '(a, i0, a, f22.18)', "crossing ", i, " of x = 0 at t = ", times(i)
    end do
    period = 2 * (times(crossings) - times(1)) / (crossings - 1)
    exact = 4 * elliptic_k(sin(release_angle / 2)) * sqrt(sys%length / sys%gravity)
    print '(a, f22.18)', "period from the crossings:     ", period
    print '(a, f22.18)', "exact period 4 K(sin(1/2)):    ", exact
    print '(a, es10.3)', "difference:                    ", period - exact
    print '(a, es10.3)', "max |(H - H0)/H0|:             ", monitor%max_energy_error
    print '(a, es10.3)', "max |phi| at the nodes:        ", monitor%max_constraint

    print '(a)', "dense output within the last step, at the displacement nodes and between them:"
    print '(a8, 3a20, a12)', "tau", "x~", "y~", "lambda~", "|q~|^2 - 1"
    call gauss_lobatto(nodes, weights)
    do i = 1, order_m
        call print_dense(nodes(i), "  (node)")
        call print_dense((nodes(i) + nodes(i + 1)) / 2, "")
    end do
    call print_dense(nodes(order_m + 1), "  (node)")

contains

    !> tau in [0, 1] where x~(tau) = 0 within the last step, by bisection on dense output.
    function crossing_tau() result(root)
        real(wp) :: root
        real(wp) :: lower, upper, x_lower
        integer :: k
        lower = 0
        upper = 1
        x_lower = dense_x(lower)
        ! Each halving gains a bit; digits(1.0_wp) halvings reach the resolution of wp.
        do k = 1, digits(1.0_wp)
            root = (lower + upper) / 2
            if ((dense_x(root) < 0) .eqv. (x_lower < 0)) then
                lower = root
            else
                upper = root
            end if
        end do
        root = (lower + upper) / 2
    end function crossing_tau

    !> Print q~, lambda~ and the constraint of the last step's dense output at tau.
    subroutine print_dense(tau, label)
        real(wp), intent(in) :: tau            !! normalised time in the last step
        character(len=*), intent(in) :: label  !! marker after the row
        real(wp) :: qd(2), pd(2), ld(1)
        call integrator%dense_output(tau, qd, pd, ld)
        print '(f8.5, 3f20.16, es12.3, a)', tau, qd, ld, sum(qd**2) - sys%length**2, label
    end subroutine print_dense

    !> x~(tau) of the last step.
    function dense_x(tau) result(x)
        real(wp), intent(in) :: tau !! normalised time in the last step
        real(wp) :: x
        real(wp) :: qd(2), pd(2), ld(1)
        call integrator%dense_output(tau, qd, pd, ld)
        x = qd(1)
    end function dense_x

    !> Complete elliptic integral of the first kind K(k) = pi / (2 agm(1, sqrt(1 - k^2))).
    pure function elliptic_k(k) result(value)
        real(wp), intent(in) :: k !! modulus, |k| < 1
        real(wp) :: value
        real(wp) :: a, b, a_next
        a = 1
        b = sqrt(1 - k**2)
        do while (abs(a - b) > epsilon(a) * a)
            a_next = (a + b) / 2
            b = sqrt(a * b)
            a = a_next
        end do
        value = acos(-1.0_wp) / (a + b)
    end function elliptic_k

end program example_planar_pendulum
