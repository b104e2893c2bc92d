!> category: internal module (use holosym)
!! The constraint manifold {phi(q) = 0, Phi(q) H_p(q, p) = 0}: residuals of a state, scaled
!! so that a tolerance tied to epsilon means "at round-off level", and the rank test of Phi.
module holosym_manifold
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    use holosym_linalg, only: lu_factor
    use holosym_status, only: int_str, is_finite
    implicit none
    private

    public :: manifold_residuals, full_rank_constraints

    !> Default tolerance on the scaled residuals: 2**10 epsilon, room for the round-off of
    !! evaluating phi and Phi H_p with a few hundred operations.
    real(wp), parameter, public :: manifold_tolerance_default = 1024 * epsilon(1.0_wp)

contains

    !> Residuals of a state: `position = max|phi(q)|`, `velocity = max|Phi(q) H_p(q,p)|`,
    !! and the same divided by their round-off scales, 1 + |q| |Phi_l| for phi_l and
    !! 1 + sum_i |Phi_li| |H_p,i| for the hidden constraint l.
    subroutine manifold_residuals(sys, q, p, position, velocity, scaled_position, scaled_velocity)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:)  !! coordinates (n)
        real(wp), intent(in) :: p(:)  !! momenta (n)
        real(wp), intent(out) :: position  !! max |phi_l(q)|
        real(wp), intent(out) :: velocity  !! max |(Phi(q) H_p(q,p))_l|
        real(wp), intent(out), optional :: scaled_position !! max |phi_l| / scale_l
        real(wp), intent(out), optional :: scaled_velocity !! max |(Phi H_p)_l| / scale_l
        real(wp) :: phi(sys%m), jac(sys%m, sys%n), hp(sys%n), hidden(sys%m)
        integer :: l

        position = 0
        velocity = 0
        if (present(scaled_position)) scaled_position = 0
        if (present(scaled_velocity)) scaled_velocity = 0
        if (sys%m == 0) return
        call sys%constraint(q, phi)
        call sys%constraint_jacobian(q, jac)
        call sys%dh_dp(q, p, hp)
        hidden = matmul(jac, hp)
        position = maxval(abs(phi))
        velocity = maxval(abs(hidden))
        do l = 1, sys%m
            if (present(scaled_position)) scaled_position = max(scaled_position, &
                abs(phi(l)) / (1 + maxval(abs(q)) * maxval(abs(jac(l, :)))))
            if (present(scaled_velocity)) scaled_velocity = max(scaled_velocity, &
                abs(hidden(l)) / (1 + sum(abs(jac(l, :)) * abs(hp))))
        end do
    end subroutine manifold_residuals

    !> True when Phi(q) has full row rank m: the LU of Phi Phi^T (m x m) finds no pivot
    !! below m epsilon relative, i.e. no singular value of Phi below ~sqrt(m epsilon) relative.
    !! Otherwise `message` says which constraint is (nearly) dependent on the others.
    function full_rank_constraints(sys, q, message) result(full_rank)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! coordinates (n)
        character(len=:), allocatable, intent(out) :: message !! why not, or empty
        logical :: full_rank
        real(wp) :: jac(sys%m, sys%n), gram(sys%m, sys%m)
        integer :: pivots(sys%m), info
        message = ""
        full_rank = .true.
        if (sys%m == 0) return
        call sys%constraint_jacobian(q, jac)
        if (.not. all(is_finite(jac))) return  ! reported as non-finite by the caller's checks
        gram = matmul(jac, transpose(jac))
        call lu_factor(gram, pivots, info)
        full_rank = info == 0
        if (.not. full_rank) message = "the constraint Jacobian Phi is rank deficient at q: " &
            // "constraint " // int_str(info) // " of " // int_str(sys%m) // " is (nearly) " // &
            "a combination of the others (pivot of Phi Phi^T below m epsilon)"
    end function full_rank_constraints

end module holosym_manifold
