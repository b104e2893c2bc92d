!> Events: the planar pendulum released at rest at 1 rad passes the vertical (x = 0) at
!! t = (2j + 1) K, K = K(sin(1/2)) = 1.674993916092613178175302844790253856807 (the
!! complete elliptic integral, 40 digits from mpmath). `integrate_events` locates the
!! passages within the steps of (M, N, G) = (8, 7, 9), h = 1/16, to the accuracy of the
!! scheme's steps, with the state there on the constraint.
!!
!!     fpm run --profile release --example events
!!
!! Output:
!!     passage 1 falling t =  1.674993916092613178175302844790233 error  2.0E-32
!!     passage 2 rising  t =  5.024981748277839534525908534370698 error  6.4E-32
!!     passage 3 falling t =  8.374969580463065890876514223951161 error  1.1E-31
!!     at the passages max |x| =  6.0E-36, max ||q|^2 - 1| =  0.0E+00
program events
    use holosym, only: wp, planar_pendulum, constrained_integrator, holosym_status_t, &
        event_t, integrate_events
    use vertical_passage, only: vertical
    implicit none

    real(wp), parameter :: quarter = 1.674993916092613178175302844790253856807_wp
    type(planar_pendulum) :: sys
    type(constrained_integrator) :: integ
    type(holosym_status_t) :: status
    type(event_t), allocatable :: found(:)
    real(wp) :: q(2), p(2)
    logical :: stopped
    integer :: j

    sys = planar_pendulum()
    call sys%initial_state(q, p)
    call integ%init(sys, 8, 7, 9, status)
    call integrate_events(integ, sys, q, p, 1.0_wp / 16, 160, vertical(), found, stopped, &
                          status)
    if (.not. status%ok()) error stop status%message
    do j = 1, size(found)
        write (*, '(a, i0, a, f36.33, a, es8.1)') "passage ", j, &
            merge(" falling t = ", " rising  t = ", found(j)%direction < 0), found(j)%t, &
            " error ", abs(found(j)%t - (2 * j - 1) * quarter)
    end do
    write (*, '(a, es8.1, a, es8.1)') "at the passages max |x| = ", &
        maxval([(abs(found(j)%q(1)), j = 1, size(found))]), ", max ||q|^2 - 1| = ", &
        maxval([(abs(sum(found(j)%q**2) - 1), j = 1, size(found))])

end program events
