!> category: internal module (use holosym)
!! Lyapunov exponents and MEGNO on the constraint manifold, from the tangent map
!! (`step_tangent`). Benettin's method: an orthonormal basis of the tangent space
!! (`tangent_basis`, 2(n - m) vectors) is carried step by step and re-orthonormalised by
!! Gram-Schmidt (a QR factorisation) after each step; the exponents are the mean
!! logarithms of the diagonal of R per unit time. The basis stays in the tangent space
!! (combinations of tangent vectors), so the spectrum is that of the motion on the
!! manifold: 2(n - m) exponents in pairs +-lambda, as the symplectic structure demands.
!!
!! MEGNO (Cincotta and Simo) from the growth of the first vector, r_j = log R_11 over
!! step j (t_j its midpoint, T_k = t_k + h_k / 2): Y_k = (2 / T_k) sum_(j<=k) r_j t_j,
!! and its mean <Y>_k = (1 / T_k) sum_(j<=k) Y_j h_j. <Y> tends to 2 on a regular (quasi-periodic, non-isochronous) orbit and grows like
!! lambda t / 2 on a chaotic one.
module holosym_lyapunov
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_NOT_INITIALIZED
    use holosym_problem, only: constrained_hamiltonian
    use holosym_tangent_space, only: tangent_basis
    use holosym_integrator, only: constrained_integrator
    implicit none
    private

    public :: lyapunov_result_t, lyapunov_tracker_t, lyapunov_spectrum

    !> What `lyapunov_spectrum` (or a tracker's `result`) measured over the steps taken.
    type :: lyapunov_result_t
        !> The 2(n - m) finite-time exponents, largest first [1/time unit]; unallocated
        !! when no step was taken.
        real(wp), allocatable :: exponents(:)
        real(wp) :: megno = 0      !! mean MEGNO <Y> at the end
        real(wp) :: megno_now = 0  !! MEGNO Y at the end
        real(wp) :: time = 0       !! time covered (the sum of the steps)
        integer :: steps = 0       !! steps taken
    end type lyapunov_result_t

    !> The measurement in progress, for runs in pieces (`start`, then `advance` as often
    !! as wanted, `result` at any point): the carried basis and the sums.
    type :: lyapunov_tracker_t
        real(wp), allocatable, private :: dq(:, :), dp(:, :) ! the orthonormal basis
        real(wp), allocatable, private :: logs(:)  ! sum of log R_ii
        real(wp), private :: weighted = 0  ! sum of r_j t_j (first vector, midpoints)
        real(wp), private :: mean_sum = 0  ! sum of Y_j h_j
        real(wp), private :: megno_now = 0 ! Y after the last step
        real(wp), private :: time = 0      ! time covered
        integer, private :: steps = 0      ! steps taken
    contains
        !> Start at (q, p): the basis of the tangent space there, the sums zero.
        procedure :: start => tracker_start
        !> Carry the basis over more steps (q, p advanced in place).
        procedure :: advance => tracker_advance
        !> The exponents and MEGNO so far.
        procedure :: result => tracker_result
    end type lyapunov_tracker_t

contains

    !> The Lyapunov spectrum and MEGNO of the orbit from (q, p) over `steps` steps of h,
    !! with an integrator set up by `init` (a tracker's `start`, `advance`, `result`). On
    !! return (q, p) is the state after the steps taken and `result` covers them (also on
    !! failure: the steps before it). Codes: those of `step_tangent` and of
    !! `tangent_basis`, HOLOSYM_INVALID_STEP_COUNT (steps < 1), HOLOSYM_INVALID_DIMENSION
    !! (no tangent space: n = m).
    subroutine lyapunov_spectrum(integ, sys, q, p, h, steps, result, status)
        type(constrained_integrator), intent(inout) :: integ !! set up for the system
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates (n): start in, end out
        real(wp), intent(inout) :: p(:) !! momenta (n): start in, end out
        real(wp), intent(in) :: h       !! step size > 0
        integer, intent(in) :: steps    !! steps >= 1
        type(lyapunov_result_t), intent(out) :: result !! the measurements
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(lyapunov_tracker_t) :: tracker
        type(holosym_status_t) :: local
        if (steps < 1) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "lyapunov_spectrum: steps " &
                // "must be >= 1; got " // int_str(steps))
            return
        end if
        call tracker%start(sys, q, p, local)
        if (local%ok()) call tracker%advance(integ, sys, q, p, h, steps, local)
        result = tracker%result()
        call set_status(status, local%code, local%message)
    end subroutine lyapunov_spectrum

    !> Start at (q, p): an orthonormal basis of the tangent space (`tangent_basis`), its
    !! first vector made generic (the normalised sum of the basis: MEGNO follows it, and a
    !! projected unit vector may lie along a symmetry and stay bounded). Codes: those of
    !! `tangent_basis`, HOLOSYM_INVALID_DIMENSION (n = m).
    subroutine tracker_start(self, sys, q, p, status)
        class(lyapunov_tracker_t), intent(out) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:) !! the start state
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp) :: unused
        integer :: count
        if (sys%n <= sys%m) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "lyapunov: the manifold of " &
                // "a system with n = m has no tangent space")
            return
        end if
        allocate (self%dq(sys%n, 2 * (sys%n - sys%m)), self%dp(sys%n, 2 * (sys%n - sys%m)))
        call tangent_basis(sys, q, p, self%dq, self%dp, count, local)
        if (.not. local%ok()) then
            deallocate (self%dq, self%dp)
            call set_status(status, local%code, local%message)
            return
        end if
        allocate (self%logs(count))
        self%dq(:, 1) = sum(self%dq, dim=2)
        self%dp(:, 1) = sum(self%dp, dim=2)
        unused = 0
        call orthonormalise(self%dq, self%dp, self%logs, unused, 0.0_wp)
        self%logs = 0
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine tracker_start

    !> Carry the basis over `steps` steps of h from (q, p) (the state where the last
    !! `start` or `advance` left it), re-orthonormalising after each. On failure (q, p) and
    !! the sums are those of the last good step. Codes: those of `step_tangent`,
    !! HOLOSYM_NOT_INITIALIZED before `start`, HOLOSYM_INVALID_STEP_COUNT (steps < 0).
    subroutine tracker_advance(self, integ, sys, q, p, h, steps, status)
        class(lyapunov_tracker_t), intent(inout) :: self
        type(constrained_integrator), intent(inout) :: integ !! set up for the system
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(inout) :: q(:), p(:) !! the state: in, advanced out
        real(wp), intent(in) :: h             !! step size > 0
        integer, intent(in) :: steps          !! steps >= 0
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        integer :: k
        if (.not. allocated(self%logs)) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "lyapunov: advance before start")
            return
        end if
        if (steps < 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "lyapunov: steps must be " &
                // ">= 0; got " // int_str(steps))
            return
        end if
        call set_status(local, HOLOSYM_SUCCESS, "")
        do k = 1, steps
            call integ%step_tangent(sys, q, p, h, self%dq, self%dp, status=local)
            if (.not. local%ok()) exit
            call orthonormalise(self%dq, self%dp, self%logs, self%weighted, self%time + h / 2)
            self%time = self%time + h
            self%steps = self%steps + 1
            self%megno_now = 2 * self%weighted / self%time
            self%mean_sum = self%mean_sum + self%megno_now * h
        end do
        call set_status(status, local%code, local%message)
    end subroutine tracker_advance

    !> The exponents (largest first) and MEGNO over the steps taken since `start`.
    pure function tracker_result(self) result(result)
        class(lyapunov_tracker_t), intent(in) :: self
        type(lyapunov_result_t) :: result
        result%steps = self%steps
        result%time = self%time
        if (self%steps == 0) return
        result%exponents = sorted_descending(self%logs / self%time)
        result%megno = self%mean_sum / self%time
        result%megno_now = self%megno_now
    end function tracker_result

    !> Gram-Schmidt of the columns of (dq, dp) (twice, for orthogonality to round-off):
    !! logs += log R_ii, and the first vector's growth, weighted by t, to `weighted`.
    pure subroutine orthonormalise(dq, dp, logs, weighted, t)
        real(wp), intent(inout) :: dq(:, :), dp(:, :), logs(:), weighted
        real(wp), intent(in) :: t
        real(wp) :: length, overlap
        integer :: i, j, pass
        do i = 1, size(dq, 2)
            do pass = 1, 2
                do j = 1, i - 1
                    overlap = dot_product(dq(:, j), dq(:, i)) + dot_product(dp(:, j), dp(:, i))
                    dq(:, i) = dq(:, i) - overlap * dq(:, j)
                    dp(:, i) = dp(:, i) - overlap * dp(:, j)
                end do
            end do
            length = sqrt(sum(dq(:, i)**2) + sum(dp(:, i)**2))
            dq(:, i) = dq(:, i) / length
            dp(:, i) = dp(:, i) / length
            logs(i) = logs(i) + log(length)
            if (i == 1) weighted = weighted + log(length) * t
        end do
    end subroutine orthonormalise

    !> The values in descending order (insertion sort: a spectrum has a few entries).
    pure function sorted_descending(values) result(sorted)
        real(wp), intent(in) :: values(:)
        real(wp) :: sorted(size(values)), key
        integer :: i, j
        sorted = values
        do i = 2, size(sorted)
            key = sorted(i)
            j = i - 1
            do while (j >= 1)
                if (sorted(j) >= key) exit
                sorted(j + 1) = sorted(j)
                j = j - 1
            end do
            sorted(j + 1) = key
        end do
    end function sorted_descending

end module holosym_lyapunov
