!> Paper Example 2: the spring-linkage mechanism, q = (x1, y1, x2, y2, s1, s2): two balls
!! in circular tracks carried by springs, joined by a rod. As in the paper's Fig. 4, a
!! coarse run (N = M - 1 = G - 2 = 1, h = 1/2) is compared with a fine one (N = 4, h = 1/8):
!! the balls' positions agree to the coarse run's accuracy, and both runs keep the three
!! constraints at round-off at every displacement node (the paper's Fig. 5).
!!
!! Run: `fpm run --example spring_linkage` (about 8 s). Output:
!!
!!     Spring-linkage mechanism (paper Example 2): ball positions (x1, y1) and (x2, y2)
!!     coarse: (M, N, G) = (2, 1, 3), h = 1/2;  fine: (M, N, G) = (5, 4, 6), h = 1/8
!!         t     run         x1         y1         x2         y2   max|diff|
!!       0.0  coarse -0.1000000  0.0000000  0.7000000  0.0000000   0.000E+00
!!              fine -0.1000000  0.0000000  0.7000000  0.0000000
!!       2.5  coarse -0.2398448 -0.0084077  0.5430326 -0.1730377   3.142E-05
!!              fine -0.2398384 -0.0084063  0.5430453 -0.1730063
!!       5.0  coarse -0.4319182 -0.0656282  0.3250838  0.1931149   1.210E-04
!!              fine -0.4320393 -0.0657305  0.3249657  0.1930039
!!       7.5  coarse -0.3421861  0.0140524  0.4490550  0.1321101   5.234E-04
!!              fine -0.3420941  0.0139473  0.4490529  0.1326335
!!      10.0  coarse -0.1594125  0.0105422  0.6269225 -0.1366896   7.771E-04
!!              fine -0.1595064  0.0107500  0.6266436 -0.1374668
!!      12.5  coarse -0.2571505 -0.0317443  0.5124800  0.1865880   1.408E-03
!!              fine -0.2566058 -0.0318981  0.5133793  0.1851802
!!      15.0  coarse -0.3564420  0.0502264  0.4048764 -0.1955262   6.283E-04
!!              fine -0.3563417  0.0502677  0.4047602 -0.1961545
!!      17.5  coarse -0.2576666 -0.0306720  0.5252026 -0.1953408   1.587E-03
!!              fine -0.2567218 -0.0308088  0.5265080 -0.1937535
!!      20.0  coarse -0.2290140 -0.0342112  0.5391378  0.1892679   3.633E-03
!!              fine -0.2307620 -0.0360935  0.5378968  0.1856352
!!     largest coarse-fine difference in the balls' positions:   3.633E-03
!!     max |(H - H0)/H0|, coarse and fine:             1.139E-03  4.538E-14
!!     max |phi| at the nodes, coarse and fine:        2.889E-34  2.889E-34
program example_spring_linkage
    use holosym, only: wp, spring_linkage, constrained_integrator, holosym_status_t
    use spring_linkage_monitor, only: linkage_monitor
    implicit none
    !> The two schemes: (M, N, G) = (N + 1, N, N + 2) with N = 1 and N = 4.
    integer, parameter :: coarse_n = 1, fine_n = 4
    !> Their step sizes, 1/2 and 1/2**3.
    real(wp), parameter :: coarse_h = 1.0_wp / 2, fine_h = 1.0_wp / 8
    !> Time between printed samples and number of samples.
    real(wp), parameter :: interval = 2.5_wp
    integer, parameter :: samples = 8
    type(spring_linkage) :: sys
    type(constrained_integrator) :: coarse, fine
    type(linkage_monitor) :: coarse_monitor, fine_monitor
    real(wp) :: qc(6), pc(6), qf(6), pf(6), largest
    integer :: k

    sys = spring_linkage()
    call sys%initial_state(qc, pc)
    qf = qc
    pf = pc
    call coarse%init(sys, coarse_n + 1, coarse_n, coarse_n + 2)
    call fine%init(sys, fine_n + 1, fine_n, fine_n + 2)
    call setup(coarse_monitor, qc, pc)
    call setup(fine_monitor, qf, pf)

    print '(a)', "Spring-linkage mechanism (paper Example 2): ball positions (x1, y1) and " // &
        "(x2, y2)"
    print '(a)', "coarse: (M, N, G) = (2, 1, 3), h = 1/2;  fine: (M, N, G) = (5, 4, 6), h = 1/8"
    print '(a5, 2x, a6, 4a11, a12)', "t", "run", "x1", "y1", "x2", "y2", "max|diff|"
    call print_sample(0.0_wp)
    largest = 0
    do k = 1, samples
        call advance(coarse, coarse_monitor, qc, pc, coarse_h)
        call advance(fine, fine_monitor, qf, pf, fine_h)
        call print_sample(k * interval)
        largest = max(largest, maxval(abs(qc(1:4) - qf(1:4))))
    end do
    print '(a, t58, es10.3)', "largest coarse-fine difference in the balls' positions:", &
        largest
    print '(a, t47, 2es11.3)', "max |(H - H0)/H0|, coarse and fine:", &
        coarse_monitor%max_energy_error, fine_monitor%max_energy_error
    print '(a, t47, 2es11.3)', "max |phi| at the nodes, coarse and fine:", &
        coarse_monitor%max_constraint, fine_monitor%max_constraint

contains

    !> Prepare a monitor for a run from (q, p).
    subroutine setup(monitor, q, p)
        type(linkage_monitor), intent(inout) :: monitor !! the monitor
        real(wp), intent(in) :: q(:)  !! initial coordinates
        real(wp), intent(in) :: p(:)  !! initial momenta
        allocate (monitor%sys, source=sys)
        monitor%energy0 = sys%hamiltonian(q, p)
    end subroutine setup

    !> Advance one run by `interval` with step size h.
    subroutine advance(integrator, monitor, q, p, h)
        type(constrained_integrator), intent(inout) :: integrator !! the run's integrator
        type(linkage_monitor), intent(inout) :: monitor !! the run's monitor
        real(wp), intent(inout) :: q(:)  !! coordinates
        real(wp), intent(inout) :: p(:)  !! momenta
        real(wp), intent(in) :: h        !! step size
        type(holosym_status_t) :: status
        call integrator%integrate(sys, q, p, h, nint(interval / h), monitor, status=status)
        if (.not. status%ok()) error stop status%message
    end subroutine advance

    !> Print both runs' ball positions at time t.
    subroutine print_sample(t)
        real(wp), intent(in) :: t !! current time
        print '(f5.1, 2x, a6, 4f11.7, es12.3)', t, "coarse", qc(1:4), &
            maxval(abs(qc(1:4) - qf(1:4)))
        print '(5x, 2x, a6, 4f11.7)', "fine", qf(1:4)
    end subroutine print_sample

end program example_spring_linkage
