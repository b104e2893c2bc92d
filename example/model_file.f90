!> A system from a model file, with no Fortran for the system itself: the four-bar linkage
!! of example/models/fourbar.hsm (crank, coupler and rocker with masses at the joints, in
!! gravity), loaded, its crank speed set by name, started from its stated velocities
!! (projected onto the constraints) and integrated 10 s with an order-16 scheme.
!!
!! Run from the project's root: `fpm run --profile release --example model_file`.
!! Output:
!!     n = 4, m = 3, separable: T
!!     the initial velocities are not tangent to the constraints (|Phi v| = 7.247)
!!     q(10)          =  0.9922185549 -0.1245083904  2.5248774333  2.4544365029
!!     max |H/H0 - 1| =  5.624E-32
!!     max |phi|      =  4.622E-33
program model_file
    use holosym, only: wp, formula_model, load_model, constrained_integrator, step_info_t, &
        holosym_status_t
    implicit none
    type(formula_model) :: linkage
    type(constrained_integrator) :: integ
    type(step_info_t) :: info
    type(holosym_status_t) :: status
    real(wp) :: q(4), p(4), energy0, energy_error, phi_max
    character(len=:), allocatable :: note
    integer :: k

    call load_model("example/models/fourbar.hsm", linkage, status)
    if (.not. status%ok()) error stop status%message  ! "FILE:LINE:COLUMN: what is wrong"
    call linkage%set_parameter("omega", 3.0_wp, status)  ! before init: masses are taken then
    print '(a, i0, a, i0, a, l1)', "n = ", linkage%n, ", m = ", linkage%m, ", separable: ", &
        linkage%is_separable()
    call linkage%initial_state(q, p, status, note)   ! velocities -> consistent momenta
    if (.not. status%ok()) error stop status%message
    print '(a)', note(:index(note, ";") - 1)       ! "...; their normal part removed"
    energy0 = linkage%hamiltonian(q, p)
    call integ%init(linkage, 8, 7, 9, status)        ! M = 8, N = M - 1, G = M + 1: order 16
    if (.not. status%ok()) error stop status%message
    energy_error = 0
    phi_max = 0
    do k = 1, 1280                                   ! h = 1/128
        call integ%step(linkage, q, p, 1.0_wp / 128, info, status)
        if (.not. status%ok()) error stop status%message
        energy_error = max(energy_error, abs(linkage%hamiltonian(q, p) / energy0 - 1))
        phi_max = max(phi_max, info%constraint_residual)
    end do
    print '(a, 4f14.10)', "q(10)          =", q
    print '(a, es10.3)', "max |H/H0 - 1| = ", energy_error
    print '(a, es10.3)', "max |phi|      = ", phi_max
end program model_file
