!> The tangent map: an orthonormal basis of the tangent space of the spherical
!! pendulum's constraint manifold (2(n - m) = 4 vectors, `tangent_basis`) carried by `step_tangent` with (M, N, G) = (8, 7, 9), h = 1/8 to T = 100. The
!! symplectic products omega(u_a, u_b) = u_a,q . u_b,p - u_a,p . u_b,q of the carried
!! vectors stay those of the start (S^T J S = J on the tangent space) to round-off
!! (relative to the square of the largest entry |S| of the vectors, which grow linearly:
!! the motion is regular), and the vectors stay tangent. The last line
!! is the CPU time of `step_tangent` against `step` on the same run (machine-dependent).
!!
!!     fpm run --profile release --example tangent
!!
!! Output:
!!     t =   25 |S^T J S - J| / |S|^2 =  2.4E-33 largest  5.1E+00 tangent residual  4.1E-34
!!     t =   50 |S^T J S - J| / |S|^2 =  4.9E-33 largest  1.1E+01 tangent residual  1.4E-33
!!     t =   75 |S^T J S - J| / |S|^2 =  4.4E-33 largest  1.9E+01 tangent residual  6.1E-34
!!     t =  100 |S^T J S - J| / |S|^2 =  9.1E-33 largest  2.2E+01 tangent residual  4.4E-35
!!     step_tangent 4 vectors:  2.0E-03 s/step, step alone  1.7E-04 s/step
program tangent
    use holosym, only: wp, spherical_pendulum, constrained_integrator, holosym_status_t, &
        tangent_basis, tangent_residual
    implicit none

    integer, parameter :: n = 3, vectors = 4, steps_per_report = 200
    real(wp), parameter :: h = 1.0_wp / 8
    type(spherical_pendulum) :: sys
    type(constrained_integrator) :: integ
    type(holosym_status_t) :: status
    real(wp) :: q(n), p(n), dq(n, 2 * n), dp(n, 2 * n), start_form(vectors, vectors)
    real(wp) :: drift, residual, size_now, q_plain(n), p_plain(n), t_tangent, t_plain, t0, t1
    integer :: k, report, step

    sys = spherical_pendulum()
    call sys%initial_state(q, p)
    call tangent_basis(sys, q, p, dq, dp, k)
    start_form = omega(dq(:, 1:vectors), dp(:, 1:vectors))
    call integ%init(sys, 8, 7, 9, status)
    if (.not. status%ok()) error stop status%message
    t_tangent = 0
    do report = 1, 4
        drift = 0
        call cpu_time(t0)
        do step = 1, steps_per_report
            call integ%step_tangent(sys, q, p, h, dq(:, 1:vectors), dp(:, 1:vectors), &
                                    status=status)
            if (.not. status%ok()) error stop status%message
            size_now = max(maxval(abs(dq(:, 1:vectors))), maxval(abs(dp(:, 1:vectors))))
            drift = max(drift, maxval(abs(omega(dq(:, 1:vectors), dp(:, 1:vectors)) - &
                                          start_form)) / max(1.0_wp, size_now)**2)
        end do
        call cpu_time(t1)
        t_tangent = t_tangent + (t1 - t0)
        residual = 0
        do k = 1, vectors
            residual = max(residual, tangent_residual(sys, q, p, dq(:, k), dp(:, k)))
        end do
        write (*, '(a, i4, a, es8.1, a, es8.1, a, es8.1)') "t = ", nint(report * &
            steps_per_report * h), " |S^T J S - J| / |S|^2 = ", drift, " largest ", &
            size_now, &
            " tangent residual ", residual
    end do
    ! The same run without the tangent vectors.
    call sys%initial_state(q_plain, p_plain)
    call cpu_time(t0)
    call integ%integrate(sys, q_plain, p_plain, h, 4 * steps_per_report, status=status)
    call cpu_time(t1)
    t_plain = t1 - t0
    write (*, '(a, i0, a, es8.1, a, es8.1, a)') "step_tangent ", vectors, " vectors: ", &
        t_tangent / (4 * steps_per_report), " s/step, step alone ", &
        t_plain / (4 * steps_per_report), " s/step"

contains

    !> omega(u_a, u_b) for the columns of (dq, dp).
    pure function omega(dq, dp) result(form)
        real(wp), intent(in) :: dq(:, :), dp(:, :)
        real(wp) :: form(size(dq, 2), size(dq, 2))
        form = matmul(transpose(dq), dp) - matmul(transpose(dp), dq)
    end function omega

end program tangent
