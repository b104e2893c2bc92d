!> Lyapunov exponents and MEGNO on the constraint manifold (`lyapunov_spectrum`), with
!! (M, N, G) = (4, 3, 5). The spherical pendulum is integrable: its exponents decay like
!! log(t)/t towards zero and MEGNO tends to 2. The double pendulum (unit masses and rods,
!! released at rest at angles 2 and 2.5 rad) is chaotic: one positive exponent, its
!! negative partner, two near zero (the energy and the flow's direction), MEGNO growing
!! like lambda t / 2; h and h/2 give the same finite-time exponents while the two
!! trajectories stay within round-off of each other.
!!
!!     fpm run --profile release --example lyapunov
!!
!! Output:
!!     spherical pendulum
!!       h =  0.1250 T =   50.0 exponents  0.054137  0.003854  0.003320 -0.060479 MEGNO   1.434
!!       h =  0.1250 T =  200.0 exponents  0.020461  0.001333  0.000424 -0.022040 MEGNO   1.788
!!       h =  0.1250 T =  800.0 exponents  0.006852  0.000430  0.000011 -0.007243 MEGNO   1.929
!!     double pendulum
!!       h =  0.0625 T =   25.0 exponents  0.489674  0.049734 -0.056120 -0.465576 MEGNO   6.149
!!       h =  0.0625 T =   50.0 exponents  0.504202  0.018073 -0.014911 -0.496441 MEGNO  13.641
!!       h =  0.0312 T =   25.0 exponents  0.489678  0.049734 -0.056121 -0.465578 MEGNO   6.141
!!       h =  0.0312 T =   50.0 exponents  0.533879  0.034518 -0.025841 -0.514401 MEGNO  13.728
program lyapunov
    use holosym, only: wp, spherical_pendulum, pendulum_chain, constrained_integrator, &
        holosym_status_t, lyapunov_spectrum, lyapunov_result_t
    implicit none

    type(spherical_pendulum) :: sphere
    type(pendulum_chain) :: chain
    real(wp) :: q(4), p(4)
    integer :: k, halving

    sphere = spherical_pendulum()
    write (*, '(a)') "spherical pendulum"
    do k = 1, 3
        call sphere%initial_state(q(1:3), p(1:3))
        call report(sphere, q(1:3), p(1:3), 0.125_wp, 400 * 4**(k - 1))
    end do
    chain = pendulum_chain(2)
    write (*, '(a)') "double pendulum"
    do halving = 0, 1
        do k = 1, 2
            call double_pendulum_start(q, p)
            call report(chain, q, p, 0.0625_wp / 2**halving, 400 * 2**halving * k)
        end do
    end do

contains

    subroutine report(sys, q, p, h, steps)
        class(*), intent(in) :: sys
        real(wp), intent(inout) :: q(:), p(:)
        real(wp), intent(in) :: h
        integer, intent(in) :: steps
        type(constrained_integrator) :: integ
        type(lyapunov_result_t) :: result
        type(holosym_status_t) :: status
        select type (sys)
        type is (spherical_pendulum)
            call integ%init(sys, 4, 3, 5, status)
            if (status%ok()) call lyapunov_spectrum(integ, sys, q, p, h, steps, result, status)
        type is (pendulum_chain)
            call integ%init(sys, 4, 3, 5, status)
            if (status%ok()) call lyapunov_spectrum(integ, sys, q, p, h, steps, result, status)
        end select
        if (.not. status%ok()) error stop status%message
        write (*, '(a, f7.4, a, f6.1, a, 4f10.6, a, f8.3)') "  h = ", h, " T = ", &
            result%time, " exponents", result%exponents, " MEGNO", result%megno
    end subroutine report

    !> Both rods released at rest at angles 2 and 2.5 rad from the downward vertical.
    pure subroutine double_pendulum_start(q, p)
        real(wp), intent(out) :: q(4), p(4)
        q = [sin(2.0_wp), -cos(2.0_wp), sin(2.0_wp) + sin(2.5_wp), -cos(2.0_wp) - cos(2.5_wp)]
        p = 0
    end subroutine double_pendulum_start

end program lyapunov
