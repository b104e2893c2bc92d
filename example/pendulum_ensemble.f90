!> An ensemble of a user-defined system: the Cartesian planar pendulum of
!! `cartesian_pendulum_model`, released from rest at 16 angles, integrated in parallel by
!! `run_ensemble` (OpenMP threads; the same call runs on MPI ranks with holosym-mpi's
!! `mpi_farm`) with one result per trajectory; a sink prints each as it completes.
!!
!!     fpm run --profile release --example pendulum_ensemble
!!
!! Output (16 "done" lines from the sink in ensemble_printer.f90, in the order of
!! completion, which depends on the threads; then the table, in id order):
!!     ...
!!     id  angle  x(T)        y(T)        max|dH/H0|
!!      1   0.10  -8.415E-02  -9.965E-01   6.984E-15
!!      ...
!!     16   1.60  -7.772E-01  -6.293E-01   6.896E-10
!!     failures: 0; Newton iterations: 13490
program pendulum_ensemble
    use holosym, only: wp, ensemble_settings_t, ensemble_states_t, ensemble_result_t, &
        run_ensemble, holosym_status_t
    use cartesian_pendulum_model, only: cartesian_pendulum
    use ensemble_printer, only: printing_sink
    implicit none

    integer, parameter :: members = 16
    type(cartesian_pendulum) :: sys
    type(ensemble_states_t) :: states
    type(ensemble_settings_t) :: settings
    type(ensemble_result_t), allocatable :: results(:)
    type(printing_sink) :: sink
    type(holosym_status_t) :: status
    real(wp) :: angle
    integer :: k

    sys = cartesian_pendulum()
    ! At rest at angle a from the downward vertical: q = (sin a, -cos a), p = 0; on the
    ! manifold, so no projection is needed.
    allocate (states%id(members), states%q(2, members), states%p(2, members))
    do k = 1, members
        angle = 0.1_wp * k
        states%id(k) = k
        states%q(:, k) = [sin(angle), -cos(angle)]
        states%p(:, k) = 0
    end do
    settings%order_m = 3
    settings%order_n = 2
    settings%gauss_points = 4
    settings%step_size = 0.0625_wp
    settings%final_time = 10

    call run_ensemble(sys, states, settings, results, status, sink)
    if (.not. status%ok()) error stop status%message

    print '(a)', "id  angle  x(T)        y(T)        max|dH/H0|"
    do k = 1, members
        print '(i2, f7.2, 3es12.3)', results(k)%id, 0.1 * k, real(results(k)%q), &
            real(results(k)%max_energy_error)
    end do
    print '(a, i0, a, i0)', "failures: ", count(results%code /= 0), &
        "; Newton iterations: ", sum(results%newton_iterations)

end program pendulum_ensemble
