!> category: internal module (use holosym)
!! A user's system checked, not trusted: each procedure and declaration of a
!! `constrained_hamiltonian` compared, at one state, with what the others imply.
!!
!! `check_system(sys, q, p, report, status)` compares
!! - `dh_dq` and `dh_dp` with differences of `hamiltonian` along two directions each,
!! - `constraint_jacobian` with differences of `constraint`,
!! - `hessian` (all three blocks) with differences of `dh_dq` and `dh_dp`,
!! - `constraint_hessian` with differences of `constraint_jacobian`,
!! - a declared `diagonal_mass` with `dh_dp` (dH/dp = p/m) and with `dh_dq` (free of p),
!! - a declared `constraint_sparsity` with the whole Phi (no nonzero left out) and
!!   `constraint_jacobian_values` with Phi at the pattern,
!! - a declared `potential_sparsity` with the second derivatives of U (with a declared
!!   mass: no nonzero left out),
!! - `dh_dq_double` with `dh_dq`,
!! - the procedures at many points (`dh_dq_points`, `dh_dp_points`, `dh_dq_double_points`,
!!   `constraint_points`, `constraint_jacobian_values_points`) with those of one point, at
!!   the state and two points next to it, to round-off.
!! The patterns are compared at the state and at a nearby state (an entry that vanishes
!! by accident at one, as 2x at x = 0, shows at the other). A directional difference is
!! Richardson-extrapolated from two step sizes, whose disagreement bounds its own error;
!! a comparison fails when the declared value misses the difference by more than that
!! bound plus `difference_tolerance` (relative), so that an error of a declaration above
!! about 1e-15 relative (real128; 1e-6 in real64) shows. The dense comparisons (the
!! Hessians, the patterns) are made while the matrices have at most
!! `dense_check_entries` entries; the report says which were left out.
!!
!! The integrator runs the check at the first start state after `init` (its setting
!! `check_system`, default on) and refuses a system that fails it with
!! HOLOSYM_INCONSISTENT_SYSTEM, naming the procedure and the entry.
module holosym_system_check
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, &
        is_finite, HOLOSYM_SUCCESS, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_INCONSISTENT_SYSTEM, HOLOSYM_NONFINITE_VALUE
    use holosym_problem, only: constrained_hamiltonian, clear_refusal, check_refusal
    implicit none
    private

    public :: check_system, system_check_report_t, check_entry_t

    !> Largest number of entries of a dense comparison (the Hessians, the patterns).
    integer(int64), parameter, public :: dense_check_entries = 1048576

    !> One comparison.
    type :: check_entry_t
        !> What was compared, e.g. "dh_dq and differences of hamiltonian".
        character(len=:), allocatable :: what
        !> The largest relative difference found (NaN-free: huge when a value is not
        !! finite).
        real(wp) :: difference = 0
        !> The tolerance it was held to.
        real(wp) :: tolerance = 0
        !> Whether the comparison was made (not left out for size or for want of a
        !! declaration).
        logical :: made = .true.
        !> Whether it passed.
        logical :: passed = .true.
        !> Where the largest difference is, or why the comparison was not made.
        character(len=:), allocatable :: detail
    end type check_entry_t

    !> What `check_system` compared and found.
    type :: system_check_report_t
        !> The comparisons, in the order of the module's list.
        type(check_entry_t), allocatable :: entries(:)
    contains
        !> The report as Markdown table lines.
        procedure :: table => report_table
        !> Whether every comparison made passed.
        procedure :: passed => report_passed
    end type system_check_report_t

    !> The value standing for "not finite" in a difference (never a NaN: no ordered
    !! comparison with it raises).
    real(wp), parameter :: not_finite = huge(1.0_wp)

contains

    !> Relative step of the differences: epsilon**(1/3) balances truncation against
    !! round-off for central differences.
    pure real(wp) function difference_step()
        difference_step = epsilon(1.0_wp)**(1.0_wp / 3)
    end function difference_step

    !> Relative tolerance of a comparison with differences, beyond the differences' own
    !! error estimate: 1e4 epsilon**(2/3) (3.3e-19 in real128, 3.7e-7 in real64).
    pure real(wp) function difference_tolerance()
        difference_tolerance = 1.0e4_wp * epsilon(1.0_wp)**(2.0_wp / 3)
    end function difference_tolerance

    !> Relative tolerance of an identity evaluated in floating point (a declared mass, Phi
    !! at its pattern): 1e3 epsilon.
    pure real(wp) function exact_tolerance()
        exact_tolerance = 1.0e3_wp * epsilon(1.0_wp)
    end function exact_tolerance

    !> Check every procedure and declaration of `sys` at (q, p) (see the module). On
    !! return `report` lists each comparison. Codes: HOLOSYM_INCONSISTENT_SYSTEM naming the
    !! first comparison that failed and where, HOLOSYM_NONFINITE_VALUE when a procedure
    !! returns NaN or Inf at the state or next to it, HOLOSYM_SIZE_MISMATCH (q, p not of
    !! size n), HOLOSYM_INVALID_ARGUMENT (q or p not finite), HOLOSYM_OUTSIDE_DOMAIN (a
    !! procedure refused the state or a point next to it, `refuse`).
    subroutine check_system(sys, q, p, report, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! coordinates (n)
        real(wp), intent(in) :: p(:) !! momenta (n)
        type(system_check_report_t), intent(out) :: report !! the comparisons
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp) :: d(size(q), 2)
        character(len=:), allocatable :: message
        integer :: k
        allocate (report%entries(0))
        call set_status(local, HOLOSYM_SUCCESS, "")
        if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(local, HOLOSYM_SIZE_MISMATCH, "check_system: q and p must have " &
                // "size n = " // int_str(sys%n))
        else if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "check_system: q or p contains " &
                // "NaN or Inf")
        else
            call clear_refusal()
            call directions(sys%n, d)
            call check_gradients(sys, q, p, d, report)
            if (sys%m > 0) call check_jacobian(sys, q, d, report)
            call check_hessian(sys, q, p, d, report)
            if (sys%m > 0) call check_constraint_hessian(sys, q, d, report)
            call check_mass(sys, q, p, report)
            if (sys%m > 0) call check_constraint_pattern(sys, q, d, report)
            call check_potential_pattern(sys, q, d, report)
            call check_double_gradient(sys, q, p, report)
            call check_points(sys, q, p, d, report)
            do k = 1, size(report%entries)
                if (.not. report%entries(k)%passed) then
                    call failure_message(report%entries(k), message)
                    call set_status(local, failure_code(report%entries(k)), message)
                    exit
                end if
            end do
            call check_refusal(local, "check_system")
        end if
        if (present(status)) then
            status = local
        else if (.not. local%ok()) then
            error stop local%message
        end if
    end subroutine check_system

    !> The code of a failed comparison: a value that is not finite, or a mismatch.
    pure integer function failure_code(entry)
        type(check_entry_t), intent(in) :: entry
        failure_code = HOLOSYM_INCONSISTENT_SYSTEM
        if (entry%difference == not_finite) failure_code = HOLOSYM_NONFINITE_VALUE
    end function failure_code

    !> The message of a failed comparison (a subroutine: texts are built on several
    !! threads, and a function result of deferred length is not safe there).
    subroutine failure_message(entry, text)
        type(check_entry_t), intent(in) :: entry
        character(len=:), allocatable, intent(out) :: text
        if (entry%difference == not_finite) then
            text = entry%what // ": a value that is not finite at the state checked"
        else
            text = entry%what // " differ by " // real_str(entry%difference) // &
                " (relative; tolerance " // real_str(entry%tolerance) // ")"
        end if
        if (len(entry%detail) > 0) text = text // ", at " // entry%detail
    end subroutine failure_message

    !> Append a comparison to the report: made unless `reason` says why not.
    subroutine add_entry(report, what, difference, tolerance, detail, reason, show)
        type(system_check_report_t), intent(inout) :: report
        character(len=*), intent(in) :: what
        real(wp), intent(in) :: difference, tolerance
        character(len=*), intent(in) :: detail
        character(len=*), intent(in), optional :: reason !! why it was not made
        logical, intent(in), optional :: show !! whether `detail` applies (default yes)
        type(check_entry_t), allocatable :: longer(:)
        integer :: k
        allocate (longer(size(report%entries) + 1))
        do k = 1, size(report%entries)
            longer(k) = report%entries(k)
        end do
        associate (e => longer(size(longer)))
            e%what = what
            e%difference = difference
            e%tolerance = tolerance
            e%detail = detail
            if (present(show)) then
                if (.not. show) e%detail = ""
            end if
            e%made = .not. present(reason)
            if (present(reason)) e%detail = reason
            e%passed = .not. e%made .or. difference <= tolerance
        end associate
        call move_alloc(longer, report%entries)
    end subroutine add_entry

    !> Two fixed unit directions whose components are all nonzero (an error in any one
    !! entry shows in the directional derivative).
    pure subroutine directions(n, d)
        integer, intent(in) :: n
        real(wp), intent(out) :: d(n, 2)
        integer :: i
        do i = 1, n
            d(i, 1) = 1 + 0.5_wp * sin(real(3 * i + 1, wp))
            d(i, 2) = merge(-1.0_wp, 1.0_wp, mod(i, 2) == 0) * &
                (1 + 0.5_wp * cos(real(5 * i + 2, wp)))
        end do
        d(:, 1) = d(:, 1) / sqrt(sum(d(:, 1)**2))
        d(:, 2) = d(:, 2) / sqrt(sum(d(:, 2)**2))
    end subroutine directions

    !> The difference step at x: epsilon**(1/3) times x's scale.
    pure real(wp) function step_at(x)
        real(wp), intent(in) :: x(:)
        step_at = difference_step() * max(1.0_wp, maxval(abs(x)))
    end function step_at

    !> Compare `declared` (a directional derivative) with central differences of values
    !! f(+h), f(-h), f(+h/2), f(-h/2): the Richardson value, with the disagreement of the
    !! two step sizes as its error bound; relative to `scale` + |declared|. Returns the
    !! relative miss beyond the bound (0 when within), `not_finite` for a value that is
    !! not finite.
    elemental real(wp) function miss(declared, plus, minus, half_plus, half_minus, h, scale)
        real(wp), intent(in) :: declared, plus, minus, half_plus, half_minus, h, scale
        real(wp) :: coarse, fine, extrapolated, bound
        miss = not_finite
        if (.not. (is_finite(declared) .and. is_finite(plus) .and. is_finite(minus) .and. &
                   is_finite(half_plus) .and. is_finite(half_minus) .and. is_finite(scale))) &
            return
        coarse = (plus - minus) / (2 * h)
        fine = (half_plus - half_minus) / h
        extrapolated = (4 * fine - coarse) / 3
        bound = 10 * abs(fine - coarse)
        miss = max(0.0_wp, abs(declared - extrapolated) - bound) / &
            max(tiny(1.0_wp), scale + abs(declared) + abs(extrapolated))
    end function miss


    !> dh_dq and dh_dp against differences of H along two directions in q and in p.
    subroutine check_gradients(sys, q, p, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        real(wp) :: gq(sys%n), gp(sys%n), worst_q, worst_p, hq, hp, energy
        integer :: k
        call sys%dh_dq(q, p, gq)
        call sys%dh_dp(q, p, gp)
        energy = sys%hamiltonian(q, p)
        hq = step_at(q)
        hp = step_at(p)
        worst_q = 0
        worst_p = 0
        do k = 1, 2
            worst_q = max(worst_q, miss(dot_product(gq, d(:, k)), &
                sys%hamiltonian(q + hq * d(:, k), p), sys%hamiltonian(q - hq * d(:, k), p), &
                sys%hamiltonian(q + hq / 2 * d(:, k), p), &
                sys%hamiltonian(q - hq / 2 * d(:, k), p), hq, gradient_scale(gq, energy, q)))
            worst_p = max(worst_p, miss(dot_product(gp, d(:, k)), &
                sys%hamiltonian(q, p + hp * d(:, k)), sys%hamiltonian(q, p - hp * d(:, k)), &
                sys%hamiltonian(q, p + hp / 2 * d(:, k)), &
                sys%hamiltonian(q, p - hp / 2 * d(:, k)), hp, gradient_scale(gp, energy, p)))
        end do
        if (.not. (all(is_finite(gq)) .and. is_finite(energy))) worst_q = not_finite
        if (.not. all(is_finite(gp))) worst_p = not_finite
        call add_entry(report, "dh_dq and differences of hamiltonian", worst_q, &
                       difference_tolerance(), "")
        call add_entry(report, "dh_dp and differences of hamiltonian", worst_p, &
                       difference_tolerance(), "")
    end subroutine check_gradients

    !> The scale of a directional derivative of f at x: |gradient| (1-norm) and |f| over the
    !! scale of x.
    pure real(wp) function gradient_scale(gradient, f, x)
        real(wp), intent(in) :: gradient(:), f, x(:)
        gradient_scale = sum(abs(gradient)) + abs(f) / max(1.0_wp, maxval(abs(x)))
    end function gradient_scale

    !> constraint_jacobian against differences of constraint, row by row.
    subroutine check_jacobian(sys, q, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        ! Phi allocated after the size test (an automatic m x n array would be on the stack
        ! for every m and n, beyond it for a long chain).
        real(wp), allocatable :: jac(:, :)
        real(wp) :: phi(sys%m), f(sys%m, 4), worst, h, row_miss(sys%m)
        integer :: k, l, where
        if (int(sys%m, int64) * sys%n > dense_check_entries) then
            call add_entry(report, "constraint_jacobian and differences of constraint", &
                0.0_wp, difference_tolerance(), "", "not made: Phi has more than " // &
                int_str(int(dense_check_entries)) // " entries")
            return
        end if
        allocate (jac(sys%m, sys%n))
        call sys%constraint_jacobian(q, jac)
        call sys%constraint(q, phi)
        h = step_at(q)
        worst = 0
        where = 0
        do k = 1, 2
            call sys%constraint(q + h * d(:, k), f(:, 1))
            call sys%constraint(q - h * d(:, k), f(:, 2))
            call sys%constraint(q + h / 2 * d(:, k), f(:, 3))
            call sys%constraint(q - h / 2 * d(:, k), f(:, 4))
            do l = 1, sys%m
                row_miss(l) = miss(dot_product(jac(l, :), d(:, k)), f(l, 1), f(l, 2), &
                    f(l, 3), f(l, 4), h, sum(abs(jac(l, :))) + abs(phi(l)) / &
                    max(1.0_wp, maxval(abs(q))))
            end do
            if (maxval(row_miss) > worst) then
                worst = maxval(row_miss)
                where = maxloc(row_miss, 1)
            end if
        end do
        if (.not. all(is_finite(jac))) worst = not_finite
        call add_entry(report, "constraint_jacobian and differences of constraint", worst, &
                       difference_tolerance(), "constraint " // int_str(where), &
                       show=where > 0)
    end subroutine check_jacobian

    !> hessian (hqq, hqp, hpp) against differences of dh_dq and dh_dp along a direction
    !! in (q, p).
    subroutine check_hessian(sys, q, p, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        real(wp), allocatable :: hqq(:, :), hqp(:, :), hpp(:, :)
        real(wp) :: gq(sys%n, 4), gp(sys%n, 4), g0q(sys%n), g0p(sys%n), h, worst
        real(wp) :: dq(sys%n), dp(sys%n), components(2 * sys%n)
        integer :: n, where
        n = sys%n
        if (3 * int(n, int64)**2 > dense_check_entries) then
            call add_entry(report, "hessian and differences of dh_dq, dh_dp", 0.0_wp, &
                difference_tolerance(), "", "not made: n^2 beyond the dense limit")
            return
        end if
        allocate (hqq(n, n), hqp(n, n), hpp(n, n))
        call sys%hessian(q, p, hqq, hqp, hpp)
        dq = d(:, 1)
        dp = d(:, 2)
        h = max(step_at(q), step_at(p))
        call sys%dh_dq(q, p, g0q)
        call sys%dh_dp(q, p, g0p)
        call sys%dh_dq(q + h * dq, p + h * dp, gq(:, 1))
        call sys%dh_dq(q - h * dq, p - h * dp, gq(:, 2))
        call sys%dh_dq(q + h / 2 * dq, p + h / 2 * dp, gq(:, 3))
        call sys%dh_dq(q - h / 2 * dq, p - h / 2 * dp, gq(:, 4))
        call sys%dh_dp(q + h * dq, p + h * dp, gp(:, 1))
        call sys%dh_dp(q - h * dq, p - h * dp, gp(:, 2))
        call sys%dh_dp(q + h / 2 * dq, p + h / 2 * dp, gp(:, 3))
        call sys%dh_dp(q - h / 2 * dq, p - h / 2 * dp, gp(:, 4))
        ! d(dH/dq) = hqq dq + hqp dp,  d(dH/dp) = hqp^T dq + hpp dp.
        components(:n) = miss(matmul(hqq, dq) + matmul(hqp, dp), gq(:, 1), gq(:, 2), &
            gq(:, 3), gq(:, 4), h, matmul(abs(hqq), abs(dq)) + matmul(abs(hqp), abs(dp)) + &
            abs(g0q) / max(1.0_wp, maxval(abs(q)), maxval(abs(p))))
        components(n + 1:) = miss(matmul(transpose(hqp), dq) + matmul(hpp, dp), gp(:, 1), &
            gp(:, 2), gp(:, 3), gp(:, 4), h, matmul(abs(transpose(hqp)), abs(dq)) + &
            matmul(abs(hpp), abs(dp)) + abs(g0p) / max(1.0_wp, maxval(abs(q)), &
            maxval(abs(p))))
        worst = maxval(components)
        where = maxloc(components, 1)
        if (.not. (all(is_finite(hqq)) .and. all(is_finite(hqp)) .and. &
                   all(is_finite(hpp)))) worst = not_finite
        call add_entry(report, "hessian and differences of dh_dq, dh_dp", worst, &
            difference_tolerance(), "row " // int_str(where - merge(0, n, where <= n)) // &
            " of d2H/d" // merge("q", "p", where <= n) // " dx")
    end subroutine check_hessian

    !> constraint_hessian against differences of constraint_jacobian along a direction.
    subroutine check_constraint_hessian(sys, q, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        real(wp), allocatable :: hessian(:, :, :), jac(:, :, :)
        real(wp) :: h, worst, value
        integer :: n, m, l, i, where_l, where_i
        n = sys%n
        m = sys%m
        if (int(n, int64)**2 * m > dense_check_entries) then
            call add_entry(report, "constraint_hessian and differences of " // &
                "constraint_jacobian", 0.0_wp, difference_tolerance(), "", &
                "not made: n^2 m beyond the dense limit")
            return
        end if
        allocate (hessian(n, n, m), jac(m, n, 5))
        call sys%constraint_hessian(q, hessian)
        h = step_at(q)
        call sys%constraint_jacobian(q + h * d(:, 1), jac(:, :, 1))
        call sys%constraint_jacobian(q - h * d(:, 1), jac(:, :, 2))
        call sys%constraint_jacobian(q + h / 2 * d(:, 1), jac(:, :, 3))
        call sys%constraint_jacobian(q - h / 2 * d(:, 1), jac(:, :, 4))
        call sys%constraint_jacobian(q, jac(:, :, 5))
        worst = 0
        where_l = 0
        where_i = 0
        do l = 1, m
            do i = 1, n
                value = miss(dot_product(hessian(i, :, l), d(:, 1)), jac(l, i, 1), &
                    jac(l, i, 2), jac(l, i, 3), jac(l, i, 4), h, sum(abs(hessian(i, :, l))) &
                    + abs(jac(l, i, 5)) / max(1.0_wp, maxval(abs(q))))
                if (value > worst) then
                    worst = value
                    where_l = l
                    where_i = i
                end if
            end do
        end do
        if (.not. all(is_finite(hessian))) worst = not_finite
        call add_entry(report, "constraint_hessian and differences of constraint_jacobian", &
            worst, difference_tolerance(), "row " // int_str(where_i) // " of constraint " // &
            int_str(where_l) // "'s Hessian", show=where_l > 0)
    end subroutine check_constraint_hessian

    !> A declared diagonal mass: dH/dp = p / m at (q, p) and at (q, 2p + 1), and dH/dq the
    !! same at both (free of p).
    subroutine check_mass(sys, q, p, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(system_check_report_t), intent(inout) :: report
        real(wp) :: mass(sys%n), gp(sys%n), gq(sys%n), gq2(sys%n), p2(sys%n), worst, scale
        integer :: k, where
        if (.not. sys%diagonal_mass(mass)) then
            call add_entry(report, "diagonal_mass and dh_dp", 0.0_wp, exact_tolerance(), "", &
                "not made: no mass declared")
            return
        end if
        worst = 0
        where = 0
        p2 = 2 * p + 1
        do k = 1, 2
            if (k == 1) call sys%dh_dp(q, p, gp)
            if (k == 2) call sys%dh_dp(q, p2, gp)
            associate (pk => merge(p, p2, k == 1))
                scale = maxval(abs(pk / mass))
                if (.not. (all(is_finite(gp)) .and. all(is_finite(mass)))) then
                    worst = not_finite
                else if (maxval(abs(gp - pk / mass)) / max(tiny(1.0_wp), scale) > worst) then
                    worst = maxval(abs(gp - pk / mass)) / max(tiny(1.0_wp), scale)
                    where = maxloc(abs(gp - pk / mass), 1)
                end if
            end associate
        end do
        call add_entry(report, "diagonal_mass and dh_dp", worst, exact_tolerance(), &
            "coordinate " // int_str(where), show=where > 0)
        call sys%dh_dq(q, p, gq)
        call sys%dh_dq(q, p2, gq2)
        worst = 0
        if (.not. (all(is_finite(gq)) .and. all(is_finite(gq2)))) then
            worst = not_finite
        else if (maxval(abs(gq)) > 0) then
            worst = maxval(abs(gq - gq2)) / maxval(abs(gq))
        else
            worst = maxval(abs(gq2))
        end if
        call add_entry(report, "diagonal_mass and dh_dq (free of p)", worst, &
            exact_tolerance(), "")
    end subroutine check_mass

    !> A declared Phi pattern: no nonzero of Phi outside it, at q and nearby, and
    !! constraint_jacobian_values equal to Phi at it.
    subroutine check_constraint_pattern(sys, q, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        integer, allocatable :: rows(:), cols(:)
        logical, allocatable :: inside(:, :)
        real(wp), allocatable :: jac(:, :), values(:)
        real(wp) :: worst, scale
        integer :: e, k, where(2)
        call sys%constraint_sparsity(rows, cols)
        if (size(rows) >= int(sys%m, int64) * sys%n) then
            call add_entry(report, "constraint_sparsity and constraint_jacobian", 0.0_wp, &
                exact_tolerance(), "", "not made: no sparse pattern declared")
            return
        end if
        if (int(sys%m, int64) * sys%n > dense_check_entries) then
            call add_entry(report, "constraint_sparsity and constraint_jacobian", 0.0_wp, &
                exact_tolerance(), "", "not made: Phi has more than " // &
                int_str(int(dense_check_entries)) // " entries")
            return
        end if
        allocate (inside(sys%m, sys%n), jac(sys%m, sys%n), values(size(rows)))
        inside = .false.
        do e = 1, size(rows)
            if (rows(e) >= 1 .and. rows(e) <= sys%m .and. cols(e) >= 1 .and. &
                cols(e) <= sys%n) inside(rows(e), cols(e)) = .true.
        end do
        worst = 0
        where = 0
        do k = 1, 2
            if (k == 1) call sys%constraint_jacobian(q, jac)
            if (k == 2) call sys%constraint_jacobian(q + 1.0e-3_wp * &
                max(1.0_wp, maxval(abs(q))) * d(:, 1), jac)
            if (.not. all(is_finite(jac))) then
                worst = not_finite
                exit
            end if
            scale = max(tiny(1.0_wp), maxval(abs(jac)))
            if (any(.not. inside .and. jac /= 0)) then
                if (maxval(abs(jac), mask=.not. inside) / scale > worst) then
                    worst = maxval(abs(jac), mask=.not. inside) / scale
                    where = maxloc(abs(jac), mask=.not. inside)
                end if
            end if
        end do
        call add_entry(report, "constraint_sparsity and constraint_jacobian", worst, &
            0.0_wp, "entry (" // int_str(where(1)) // ", " // int_str(where(2)) // &
            ") left out", show=where(1) > 0)
        call sys%constraint_jacobian(q, jac)
        call sys%constraint_jacobian_values(q, rows, cols, values)
        worst = 0
        where = 0
        do e = 1, size(rows)
            if (.not. is_finite(values(e))) then
                worst = not_finite
                exit
            end if
            if (abs(values(e) - jac(rows(e), cols(e))) / max(tiny(1.0_wp), &
                maxval(abs(jac))) > worst) then
                worst = abs(values(e) - jac(rows(e), cols(e))) / max(tiny(1.0_wp), &
                    maxval(abs(jac)))
                where = [rows(e), cols(e)]
            end if
        end do
        call add_entry(report, "constraint_jacobian_values and constraint_jacobian", worst, &
            exact_tolerance(), "entry (" // int_str(where(1)) // ", " // int_str(where(2)) &
            // ")", show=where(1) > 0)
    end subroutine check_constraint_pattern

    !> A declared pattern of the Hessian of U (with a declared mass): no second derivative
    !! of U outside it (from differences of dh_dq, along unit vectors), at q and nearby.
    subroutine check_potential_pattern(sys, q, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        integer, allocatable :: rows(:), cols(:)
        logical, allocatable :: inside(:, :)
        real(wp), allocatable :: hessian(:, :)
        real(wp) :: mass(sys%n), plus(sys%n), minus(sys%n), x(sys%n), zero(sys%n), h, worst
        real(wp) :: scale, noise
        integer :: e, i, k, n, where(2)
        n = sys%n
        call sys%potential_sparsity(rows, cols)
        if (.not. sys%diagonal_mass(mass) .or. size(rows) >= int(n, int64)**2) then
            call add_entry(report, "potential_sparsity and differences of dh_dq", 0.0_wp, &
                0.0_wp, "", "not made: no sparse pattern declared with a mass")
            return
        end if
        if (int(n, int64)**2 > dense_check_entries) then
            call add_entry(report, "potential_sparsity and differences of dh_dq", 0.0_wp, &
                0.0_wp, "", "not made: n^2 beyond the dense limit")
            return
        end if
        allocate (inside(n, n), hessian(n, n))
        inside = .false.
        do i = 1, n
            inside(i, i) = .true.
        end do
        do e = 1, size(rows)
            if (rows(e) >= 1 .and. rows(e) <= n .and. cols(e) >= 1 .and. cols(e) <= n) then
                inside(rows(e), cols(e)) = .true.
                inside(cols(e), rows(e)) = .true.
            end if
        end do
        zero = 0
        worst = 0
        where = 0
        do k = 1, 2
            x = q
            if (k == 2) x = q + 1.0e-3_wp * max(1.0_wp, maxval(abs(q))) * d(:, 1)
            h = step_at(x)
            do i = 1, n
                x(i) = x(i) + h
                call sys%dh_dq(x, zero, plus)
                x(i) = x(i) - 2 * h
                call sys%dh_dq(x, zero, minus)
                x(i) = x(i) + h
                hessian(:, i) = (plus - minus) / (2 * h)
            end do
            if (.not. all(is_finite(hessian))) then
                worst = not_finite
                exit
            end if
            ! The differences' noise: epsilon |dH/dq| / h; an entry above 1e3 times it
            ! outside the pattern is a second derivative left out.
            call sys%dh_dq(x, zero, plus)
            noise = 1.0e3_wp * epsilon(1.0_wp) * max(1.0_wp, maxval(abs(plus))) / h
            scale = max(noise, maxval(abs(hessian)))
            if (any(.not. inside .and. abs(hessian) > noise)) then
                if (maxval(abs(hessian), mask=.not. inside) / scale > worst) then
                    worst = maxval(abs(hessian), mask=.not. inside) / scale
                    where = maxloc(abs(hessian), mask=.not. inside)
                end if
            end if
        end do
        call add_entry(report, "potential_sparsity and differences of dh_dq", worst, &
            0.0_wp, "entry (" // int_str(where(1)) // ", " // int_str(where(2)) // &
            ") left out", show=where(1) > 0)
    end subroutine check_potential_pattern

    !> dh_dq_double against dh_dq (rounded), to real64 round-off.
    subroutine check_double_gradient(sys, q, p, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(system_check_report_t), intent(inout) :: report
        real(wp) :: g(sys%n), worst
        real(dp) :: gd(sys%n), qd(sys%n), pd(sys%n)
        if (maxval(abs(q)) > huge(1.0_dp) / 2 .or. maxval(abs(p)) > huge(1.0_dp) / 2) then
            call add_entry(report, "dh_dq_double and dh_dq", 0.0_wp, 0.0_wp, "", &
                "not made: the state is beyond the range of real64")
            return
        end if
        qd = real(q, dp)
        pd = real(p, dp)
        call sys%dh_dq(real(qd, wp), real(pd, wp), g)
        call sys%dh_dq_double(qd, pd, gd)
        worst = 0
        if (.not. (all(is_finite(g)) .and. all(is_finite(real(gd, wp))))) then
            worst = not_finite
        else if (maxval(abs(g)) > 0) then
            worst = maxval(abs(real(gd, wp) - g)) / maxval(abs(g))
        end if
        call add_entry(report, "dh_dq_double and dh_dq", worst, &
            1.0e3_wp * real(epsilon(1.0_dp), wp), "")
    end subroutine check_double_gradient

    !> The procedures at many points against those of one point, at the state and at two
    !! points next to it (a column each), to round-off (`exact_tolerance`; real64 round-off
    !! for `dh_dq_double_points`).
    subroutine check_points(sys, q, p, d, report)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), d(:, :)
        type(system_check_report_t), intent(inout) :: report
        integer, parameter :: k = 3
        real(wp) :: qs(sys%n, k), ps(sys%n, k), many(sys%n, k), one(sys%n, k)
        real(wp) :: phi_many(sys%m, k), phi_one(sys%m, k)
        real(dp) :: low_q(sys%n, k), low_p(sys%n, k), low_many(sys%n, k), low_one(sys%n, k)
        real(wp), allocatable :: pv_many(:, :), pv_one(:, :)
        integer, allocatable :: rows(:), columns(:)
        integer :: j
        qs(:, 1) = q
        qs(:, 2) = q + step_at(q) * d(:, 1)
        qs(:, 3) = q - step_at(q) * d(:, 2)
        ps(:, 1) = p
        ps(:, 2) = p - step_at(p) * d(:, 2)
        ps(:, 3) = p + step_at(p) * d(:, 1)
        call sys%dh_dq_points(qs, ps, many)
        do j = 1, k
            call sys%dh_dq(qs(:, j), ps(:, j), one(:, j))
        end do
        call add_gap(report, "dh_dq_points and dh_dq", many, one, exact_tolerance())
        call sys%dh_dp_points(qs, ps, many)
        do j = 1, k
            call sys%dh_dp(qs(:, j), ps(:, j), one(:, j))
        end do
        call add_gap(report, "dh_dp_points and dh_dp", many, one, exact_tolerance())
        if (maxval(abs(qs)) > huge(1.0_dp) / 2 .or. maxval(abs(ps)) > huge(1.0_dp) / 2) then
            call add_entry(report, "dh_dq_double_points and dh_dq_double", 0.0_wp, 0.0_wp, &
                "", "not made: the state is beyond the range of real64")
        else
            low_q = real(qs, dp)
            low_p = real(ps, dp)
            call sys%dh_dq_double_points(low_q, low_p, low_many)
            do j = 1, k
                call sys%dh_dq_double(low_q(:, j), low_p(:, j), low_one(:, j))
            end do
            call add_gap(report, "dh_dq_double_points and dh_dq_double", real(low_many, wp), &
                real(low_one, wp), 1.0e3_wp * real(epsilon(1.0_dp), wp))
        end if
        if (sys%m == 0) return
        call sys%constraint_points(qs, phi_many)
        do j = 1, k
            call sys%constraint(qs(:, j), phi_one(:, j))
        end do
        call add_gap(report, "constraint_points and constraint", phi_many, phi_one, &
            exact_tolerance())
        call sys%constraint_sparsity(rows, columns)
        if (size(rows) /= size(columns) .or. any(rows < 1) .or. any(rows > sys%m) .or. &
            any(columns < 1) .or. any(columns > sys%n)) then
            call add_entry(report, "constraint_jacobian_values_points and " // &
                "constraint_jacobian_values", 0.0_wp, 0.0_wp, "", &
                "not made: the declared pattern is invalid")
            return
        end if
        allocate (pv_many(size(rows), k), pv_one(size(rows), k))
        call sys%constraint_jacobian_values_points(qs, rows, columns, pv_many)
        do j = 1, k
            call sys%constraint_jacobian_values(qs(:, j), rows, columns, pv_one(:, j))
        end do
        call add_gap(report, "constraint_jacobian_values_points and " // &
            "constraint_jacobian_values", pv_many, pv_one, exact_tolerance())
    end subroutine check_points

    !> Add the comparison of values at many points with those of one point: the largest
    !! difference relative to the largest value of its point, and where it is.
    subroutine add_gap(report, what, many, one, tolerance)
        type(system_check_report_t), intent(inout) :: report
        character(len=*), intent(in) :: what
        real(wp), intent(in) :: many(:, :), one(:, :)
        real(wp), intent(in) :: tolerance
        real(wp) :: worst, gap, scale
        integer :: i, j, at_i, at_j
        worst = 0
        at_i = 1
        at_j = 1
        do j = 1, size(one, 2)
            scale = max(tiny(1.0_wp), maxval(abs(one(:, j)), mask=is_finite(one(:, j))))
            do i = 1, size(one, 1)
                if (.not. (is_finite(many(i, j)) .and. is_finite(one(i, j)))) then
                    gap = not_finite
                else
                    gap = abs(many(i, j) - one(i, j)) / scale
                end if
                if (gap > worst) then
                    worst = gap
                    at_i = i
                    at_j = j
                end if
            end do
        end do
        call add_entry(report, what, worst, tolerance, "entry " // int_str(at_i) // &
            " at point " // int_str(at_j) // " of 3 (the state and two next to it)", &
            show=worst > 0)
    end subroutine add_gap

    !> The report as Markdown table lines: the header, then a line per comparison.
    function report_table(self) result(lines)
        class(system_check_report_t), intent(in) :: self
        character(len=200), allocatable :: lines(:)
        integer :: k
        character(len=:), allocatable :: verdict
        allocate (lines(size(self%entries) + 2))
        lines(1) = "| comparison | difference | tolerance | verdict |"
        lines(2) = "|---|---|---|---|"
        do k = 1, size(self%entries)
            associate (e => self%entries(k))
                if (.not. e%made) then
                    lines(k + 2) = "| " // e%what // " | — | — | " // e%detail // " |"
                    cycle
                end if
                verdict = "ok"
                if (.not. e%passed) verdict = "**fails**"
                if (len(e%detail) > 0 .and. .not. e%passed) verdict = verdict // " (" // &
                    e%detail // ")"
                if (e%difference == not_finite) then
                    lines(k + 2) = "| " // e%what // " | not finite | " // &
                        real_str(e%tolerance) // " | " // verdict // " |"
                else
                    lines(k + 2) = "| " // e%what // " | " // real_str(e%difference) // &
                        " | " // real_str(e%tolerance) // " | " // verdict // " |"
                end if
            end associate
        end do
    end function report_table

    !> Whether every comparison made passed.
    pure logical function report_passed(self) result(passed)
        class(system_check_report_t), intent(in) :: self
        integer :: k
        passed = .true.
        do k = 1, size(self%entries)
            passed = passed .and. self%entries(k)%passed
        end do
    end function report_passed

end module holosym_system_check
