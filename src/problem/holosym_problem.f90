!> category: internal module (use holosym)
!! The problem interface: a Hamiltonian system with holonomic constraints.
!!
!! A user defines a system by extending `constrained_hamiltonian`, setting the sizes
!! `n` (coordinates) and `m` (constraints), and implementing five procedures:
!! H(q,p), dH/dq, dH/dp, phi(q) and Phi(q) = dphi/dq. Parameters of the system are
!! components of the extended type. Second derivatives (`hessian`,
!! `constraint_hessian`) are optional: the defaults use central differences of the
!! first derivatives, accurate to about epsilon**(2/3) relative, which is enough for
!! Newton's method to converge to full precision.
!!
!! Equations of motion: q' = dH/dp, p' = -dH/dq - Phi(q)^T lambda, phi(q) = 0.
!!
!! What more a system can say is optional and makes the step cheaper (the reduced step of
!! `holosym_reduced_step`, chosen automatically when `diagonal_mass` is declared):
!! - `diagonal_mass`: H = p^T M^-1 p / 2 + U(q) with a constant diagonal mass matrix M
!!   (Cartesian coordinates of point masses). The momenta are then eliminated from the
!!   step equations, which leaves positions and multipliers as unknowns.
!! - `constraint_sparsity` with `constraint_jacobian_values`: the nonzero pattern of Phi
!!   and its values, so that no m x n matrix is ever formed;
!! - `potential_sparsity`: the nonzero pattern of the Hessian of U.
!! With both patterns declared, the step's linear algebra is banded (after a reordering
!! of the unknowns) and its cost grows linearly with the size of a chain-like system.
!!
!! The steps evaluate the system at all Gauss points, or at all nodes, of a step in one
!! call: `dh_dq_points`, `dh_dp_points`, `dh_dq_double_points`, `constraint_points` and
!! `constraint_jacobian_values_points` take the points as the columns of a matrix. Their
!! defaults call the procedures above point by point; a system overrides them to evaluate
!! the points together (a loop over points inside each formula, which the compiler
!! vectorizes; systems from formulas do so). An override must give what the procedure of
!! one point gives, to round-off: the system check compares them.
!!
!! A procedure called at a point outside the system's domain (a square root of a negative
!! number, a singular configuration of the model) calls `self%refuse(reason)` and returns
!! any finite values: the library's call that needed the value fails with
!! HOLOSYM_OUTSIDE_DOMAIN and the reason, the caller's state unchanged (as minpack's
!! `iflag < 0`). Refusals are kept per thread (OpenMP), so ensembles refuse per member.
module holosym_problem
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, set_status, HOLOSYM_OUTSIDE_DOMAIN
    implicit none
    private

    public :: constrained_hamiltonian, difference_hessian, difference_constraint_hessian
    public :: clear_refusal, refusal_pending, check_refusal

    !> Length kept of a refusal's reason (longer reasons are cut).
    integer, parameter :: reason_length = 400
    !> Whether a procedure of the system refused a point since `clear_refusal`, and the
    !! first reason given (per thread: the members of an ensemble refuse independently).
    logical, save :: refused = .false.
    character(len=reason_length), save :: refusal_reason = ""
    !$omp threadprivate(refused, refusal_reason)


    !> Abstract constrained Hamiltonian system. Extend it and implement the deferred bindings.
    type, abstract :: constrained_hamiltonian
        !> Number of coordinates q (and momenta p), n >= 1.
        integer :: n = 0
        !> Number of holonomic constraints, 0 <= m < n.
        integer :: m = 0
    contains
        !> H(q, p).
        procedure(hamiltonian_interface), deferred :: hamiltonian
        !> dH/dq(q, p), size n.
        procedure(gradient_interface), deferred :: dh_dq
        !> dH/dp(q, p), size n.
        procedure(gradient_interface), deferred :: dh_dp
        !> phi(q), size m.
        procedure(constraint_interface), deferred :: constraint
        !> Phi(q) = dphi/dq, m x n: Phi(l, i) = d phi_l / d q_i.
        procedure(constraint_jacobian_interface), deferred :: constraint_jacobian
        !> Second derivatives of H (optional; default: central differences of the gradients).
        procedure :: hessian => difference_hessian
        !> Second derivatives of phi (optional; default: central differences of Phi).
        procedure :: constraint_hessian => difference_constraint_hessian
        !> Optional declaration H = p^T M^-1 p / 2 + U(q) with constant diagonal M
        !! (default: not declared).
        procedure :: diagonal_mass => undeclared_mass
        !> Optional nonzero pattern of Phi (default: dense).
        procedure :: constraint_sparsity => dense_constraint_sparsity
        !> Values of Phi at the declared pattern (default: gathered from
        !! `constraint_jacobian`; override it when the pattern is sparse).
        procedure :: constraint_jacobian_values => gathered_constraint_values
        !> Optional nonzero pattern of the Hessian of U (default: dense).
        procedure :: potential_sparsity => dense_potential_sparsity
        !> dH/dq in real64 arithmetic, for the reduced step's first (real64) Newton
        !! iterations (optional; default: `dh_dq` in working precision, rounded).
        procedure :: dh_dq_double => rounded_dh_dq
        !> dH/dq at k points (the columns of q and p) in one call (optional; default:
        !! `dh_dq` point by point).
        procedure :: dh_dq_points => pointwise_dh_dq
        !> dH/dp at k points in one call (optional; default: `dh_dp` point by point).
        procedure :: dh_dp_points => pointwise_dh_dp
        !> dH/dq in real64 at k points in one call (optional; default: `dh_dq_double` point
        !! by point).
        procedure :: dh_dq_double_points => pointwise_dh_dq_double
        !> phi at k points in one call (optional; default: `constraint` point by point).
        procedure :: constraint_points => pointwise_constraint
        !> Phi at the declared pattern at k points in one call (optional; default:
        !! `constraint_jacobian_values` point by point).
        procedure :: constraint_jacobian_values_points => pointwise_constraint_values
        !> Say that the point of the current call lies outside the system's domain (call it
        !! from any of the procedures above, then return finite values).
        procedure, non_overridable :: refuse => refuse_point
    end type constrained_hamiltonian

    abstract interface
        !> Value of the Hamiltonian.
        function hamiltonian_interface(self, q, p) result(energy)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:) !! coordinates (n)
            real(wp), intent(in) :: p(:) !! momenta (n)
            real(wp) :: energy
        end function hamiltonian_interface

        !> A gradient of the Hamiltonian (with respect to q or to p).
        subroutine gradient_interface(self, q, p, gradient)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)         !! coordinates (n)
            real(wp), intent(in) :: p(:)         !! momenta (n)
            real(wp), intent(out) :: gradient(:) !! the gradient (n)
        end subroutine gradient_interface

        !> Constraint values phi(q).
        subroutine constraint_interface(self, q, phi)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)     !! coordinates (n)
            real(wp), intent(out) :: phi(:)  !! constraint values (m)
        end subroutine constraint_interface

        !> Constraint Jacobian Phi(q) = dphi/dq.
        subroutine constraint_jacobian_interface(self, q, jacobian)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)             !! coordinates (n)
            real(wp), intent(out) :: jacobian(:, :)  !! m x n, jacobian(l, i) = dphi_l/dq_i
        end subroutine constraint_jacobian_interface
    end interface

contains

    !> Refuse the point of the current call: the library's call that needed the value
    !! fails with HOLOSYM_OUTSIDE_DOMAIN and `reason` (the first reason given is kept).
    !! The procedure that refuses still returns (finite values; they are not used).
    subroutine refuse_point(self, reason)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        character(len=*), intent(in) :: reason !! why the point cannot be evaluated
        if (refused) return
        refused = .true.
        refusal_reason = reason
        if (len_trim(refusal_reason) == 0) refusal_reason = "(no reason given)"
    end subroutine refuse_point

    !> Forget earlier refusals of this thread (before a call that evaluates the system).
    subroutine clear_refusal()
        ! The reason is written by the next refusal (blanking it here would cost every
        ! step a string fill).
        refused = .false.
    end subroutine clear_refusal

    !> Whether a procedure of the system refused a point since `clear_refusal`.
    logical function refusal_pending()
        refusal_pending = refused
    end function refusal_pending

    !> HOLOSYM_OUTSIDE_DOMAIN with `context` and the reason in `status` when a procedure
    !! of the system refused a point since `clear_refusal` (`status` untouched otherwise).
    subroutine check_refusal(status, context)
        type(holosym_status_t), intent(inout) :: status !! set when a point was refused
        character(len=*), intent(in) :: context !! where, e.g. "step 3 (h = 0.125)"
        ! The message is built apart: the check runs after every evaluation of a step.
        if (refused) call report_refusal(status, context)
    end subroutine check_refusal

    !> The status of `check_refusal` when a point was refused.
    subroutine report_refusal(status, context)
        type(holosym_status_t), intent(inout) :: status
        character(len=*), intent(in) :: context
        character(len=:), allocatable :: prefix
        prefix = ""
        if (len(context) > 0) prefix = context // ": "
        call set_status(status, HOLOSYM_OUTSIDE_DOMAIN, prefix // &
            "the system refused the point: " // trim(refusal_reason))
    end subroutine report_refusal

    !> Relative step of the default central differences: epsilon**(1/3) balances
    !! truncation (step**2) against round-off (epsilon/step). A function rather than a
    !! named constant because not every compiler folds real128 powers.
    pure real(wp) function difference_step()
        difference_step = epsilon(1.0_wp)**(1.0_wp / 3)
    end function difference_step

    !> Default `diagonal_mass`: nothing declared. A system whose Hamiltonian is
    !! H = sum_i p_i^2 / (2 mass_i) + U(q) overrides it, sets `mass` and returns .true.;
    !! its `dh_dq` must then not depend on p, and `dh_dp` must return p / mass.
    logical function undeclared_mass(self, mass) result(declared)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(out) :: mass(:) !! the diagonal of M (n), positive
        mass = 1
        declared = .false.
    end function undeclared_mass

    !> Default `constraint_sparsity`: every entry of Phi may be nonzero. An override
    !! returns the (row, column) pairs of the entries that may be nonzero, row = constraint
    !! l in 1..m, column = coordinate i in 1..n, each pair once, in the order in which
    !! `constraint_jacobian_values` returns their values. When n m does not fit the default
    !! integer the default returns the invalid pattern ([0], [0]), which `init` reports.
    subroutine dense_constraint_sparsity(self, rows, columns)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        integer, allocatable, intent(out) :: rows(:)    !! constraint index of each entry
        integer, allocatable, intent(out) :: columns(:) !! coordinate index of each entry
        integer :: l, i
        if (int(self%m, int64) * self%n > huge(0)) then
            ! Too many entries for the default integer: an invalid pattern, which the
            ! caller reports (declare the sparsity instead).
            rows = [0]
            columns = [0]
            return
        end if
        allocate (rows(self%m * self%n), columns(self%m * self%n))
        do i = 1, self%n
            do l = 1, self%m
                rows(l + (i - 1) * self%m) = l
                columns(l + (i - 1) * self%m) = i
            end do
        end do
    end subroutine dense_constraint_sparsity

    !> Default `constraint_jacobian_values`: Phi(q) from `constraint_jacobian`, gathered at
    !! the pattern of `constraint_sparsity` (forms the m x n matrix: override it together
    !! with a sparse pattern).
    subroutine gathered_constraint_values(self, q, rows, columns, values)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)         !! coordinates (n)
        integer, intent(in) :: rows(:)       !! pattern from `constraint_sparsity`
        integer, intent(in) :: columns(:)    !! pattern from `constraint_sparsity`
        real(wp), intent(out) :: values(:)   !! Phi(rows(e), columns(e)) for each entry e
        ! Up to this many entries the Jacobian lives on the stack (no allocation per call).
        integer, parameter :: stack_entries = 256
        real(wp), target :: buffer(stack_entries)
        real(wp), pointer :: small(:, :)
        real(wp), allocatable :: jacobian(:, :)
        if (self%m * self%n <= stack_entries) then
            small(1:self%m, 1:self%n) => buffer(1:self%m * self%n)
            call self%constraint_jacobian(q, small)
            call gather(small)
        else
            allocate (jacobian(self%m, self%n))
            call self%constraint_jacobian(q, jacobian)
            call gather(jacobian)
        end if
    contains
        subroutine gather(full)
            real(wp), intent(in) :: full(:, :)
            integer :: e
            do e = 1, size(rows)
                values(e) = full(rows(e), columns(e))
            end do
        end subroutine gather
    end subroutine gathered_constraint_values

    !> Default `dh_dq_double`: `dh_dq` at the arguments in working precision, rounded to
    !! real64. A system whose dH/dq involves elementary functions overrides it with the same
    !! formula in real64 arithmetic: a real128 cos costs about 300 times a real64 one, and
    !! the reduced step's real64 iterations need only real64 accuracy (the final iterations
    !! always use `dh_dq`).
    subroutine rounded_dh_dq(self, q, p, gradient)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(dp), intent(in) :: q(:)         !! coordinates (n)
        real(dp), intent(in) :: p(:)         !! momenta (n)
        real(dp), intent(out) :: gradient(:) !! dH/dq (n)
        real(wp) :: g(size(q))
        call self%dh_dq(real(q, wp), real(p, wp), g)
        gradient = real(g, dp)
    end subroutine rounded_dh_dq

    !> Default `dh_dq_points`: `dh_dq` at each point. An override evaluates all points in
    !! one pass (gradients(:, j) = dH/dq(q(:, j), p(:, j)) to round-off).
    subroutine pointwise_dh_dq(self, q, p, gradients)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:, :)          !! coordinates (n x k), a point per column
        real(wp), intent(in) :: p(:, :)          !! momenta (n x k)
        real(wp), intent(out) :: gradients(:, :) !! dH/dq at each point (n x k)
        integer :: j
        do j = 1, size(q, 2)
            call self%dh_dq(q(:, j), p(:, j), gradients(:, j))
        end do
    end subroutine pointwise_dh_dq

    !> Default `dh_dp_points`: `dh_dp` at each point.
    subroutine pointwise_dh_dp(self, q, p, gradients)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:, :)          !! coordinates (n x k), a point per column
        real(wp), intent(in) :: p(:, :)          !! momenta (n x k)
        real(wp), intent(out) :: gradients(:, :) !! dH/dp at each point (n x k)
        integer :: j
        do j = 1, size(q, 2)
            call self%dh_dp(q(:, j), p(:, j), gradients(:, j))
        end do
    end subroutine pointwise_dh_dp

    !> Default `dh_dq_double_points`: `dh_dq_double` at each point.
    subroutine pointwise_dh_dq_double(self, q, p, gradients)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(dp), intent(in) :: q(:, :)          !! coordinates (n x k), a point per column
        real(dp), intent(in) :: p(:, :)          !! momenta (n x k)
        real(dp), intent(out) :: gradients(:, :) !! dH/dq at each point (n x k)
        integer :: j
        do j = 1, size(q, 2)
            call self%dh_dq_double(q(:, j), p(:, j), gradients(:, j))
        end do
    end subroutine pointwise_dh_dq_double

    !> Default `constraint_points`: `constraint` at each point.
    subroutine pointwise_constraint(self, q, phi)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:, :)    !! coordinates (n x k), a point per column
        real(wp), intent(out) :: phi(:, :) !! phi at each point (m x k)
        integer :: j
        do j = 1, size(q, 2)
            call self%constraint(q(:, j), phi(:, j))
        end do
    end subroutine pointwise_constraint

    !> Default `constraint_jacobian_values_points`: `constraint_jacobian_values` at each
    !! point.
    subroutine pointwise_constraint_values(self, q, rows, columns, values)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:, :)       !! coordinates (n x k), a point per column
        integer, intent(in) :: rows(:)        !! pattern from `constraint_sparsity`
        integer, intent(in) :: columns(:)     !! pattern from `constraint_sparsity`
        real(wp), intent(out) :: values(:, :) !! values(e, j) = Phi(rows(e), columns(e)) at
                                              !! point j
        integer :: j
        do j = 1, size(q, 2)
            call self%constraint_jacobian_values(q(:, j), rows, columns, values(:, j))
        end do
    end subroutine pointwise_constraint_values

    !> Default `potential_sparsity`: every second derivative of U may be nonzero. An
    !! override returns the pairs (i, k) with d2U/dq_i dq_k possibly nonzero (either
    !! triangle or both; the diagonal may be left out). A potential linear in q
    !! (uniform gravity) returns two empty arrays. When n^2 does not fit the default integer
    !! the default returns the invalid pattern ([0], [0]), which `init` reports.
    subroutine dense_potential_sparsity(self, rows, columns)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        integer, allocatable, intent(out) :: rows(:)    !! first coordinate of each pair
        integer, allocatable, intent(out) :: columns(:) !! second coordinate of each pair
        integer :: i, k
        if (int(self%n, int64)**2 > huge(0)) then
            ! Too many entries for the default integer: an invalid pattern, which the
            ! caller reports (declare the sparsity instead).
            rows = [0]
            columns = [0]
            return
        end if
        allocate (rows(self%n**2), columns(self%n**2))
        do k = 1, self%n
            do i = 1, self%n
                rows(i + (k - 1) * self%n) = i
                columns(i + (k - 1) * self%n) = k
            end do
        end do
    end subroutine dense_potential_sparsity

    !> Default second derivatives of H by central differences of `dh_dq` and `dh_dp`:
    !! `hqq(i,k) = d2H/dq_i dq_k`, `hqp(i,k) = d2H/dq_i dp_k`, `hpp(i,k) = d2H/dp_i dp_k`.
    !! Override it with exact derivatives for speed (6n gradient calls are saved per call).
    !! Public so that an integrator can ignore a user's `hessian` (for comparisons).
    subroutine difference_hessian(self, q, p, hqq, hqp, hpp)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)        !! coordinates (n)
        real(wp), intent(in) :: p(:)        !! momenta (n)
        real(wp), intent(out) :: hqq(:, :)  !! n x n
        real(wp), intent(out) :: hqp(:, :)  !! n x n
        real(wp), intent(out) :: hpp(:, :)  !! n x n
        real(wp) :: shifted(size(q)), plus(size(q)), minus(size(q)), step, upper, lower
        integer :: k

        do k = 1, size(q)
            ! Differencing the representable neighbours keeps the divisor exact.
            step = difference_step() * max(1.0_wp, abs(q(k)))
            upper = q(k) + step
            lower = q(k) - step
            shifted = q
            shifted(k) = upper
            call self%dh_dq(shifted, p, plus)
            shifted(k) = lower
            call self%dh_dq(shifted, p, minus)
            hqq(:, k) = (plus - minus) / (upper - lower)
        end do
        do k = 1, size(p)
            step = difference_step() * max(1.0_wp, abs(p(k)))
            upper = p(k) + step
            lower = p(k) - step
            shifted = p
            shifted(k) = upper
            call self%dh_dq(q, shifted, plus)
            shifted(k) = lower
            call self%dh_dq(q, shifted, minus)
            hqp(:, k) = (plus - minus) / (upper - lower)
            shifted(k) = upper
            call self%dh_dp(q, shifted, plus)
            shifted(k) = lower
            call self%dh_dp(q, shifted, minus)
            hpp(:, k) = (plus - minus) / (upper - lower)
        end do
    end subroutine difference_hessian

    !> Default second derivatives of the constraints by central differences of
    !! `constraint_jacobian`: `hessian(i, k, l) = d2 phi_l / dq_i dq_k` (2n Jacobian calls).
    subroutine difference_constraint_hessian(self, q, hessian)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)              !! coordinates (n)
        real(wp), intent(out) :: hessian(:, :, :) !! n x n x m
        real(wp) :: shifted(size(q)), plus(self%m, size(q)), minus(self%m, size(q))
        real(wp) :: step, upper, lower
        integer :: k, l

        do k = 1, size(q)
            step = difference_step() * max(1.0_wp, abs(q(k)))
            upper = q(k) + step
            lower = q(k) - step
            shifted = q
            shifted(k) = upper
            call self%constraint_jacobian(shifted, plus)
            shifted(k) = lower
            call self%constraint_jacobian(shifted, minus)
            do l = 1, self%m
                hessian(:, k, l) = (plus(l, :) - minus(l, :)) / (upper - lower)
            end do
        end do
    end subroutine difference_constraint_hessian

end module holosym_problem
