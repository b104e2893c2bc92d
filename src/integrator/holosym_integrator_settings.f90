!> category: internal submodule (use holosym)
!! The settings of `constrained_integrator`: the check of their ranges before a step, their
!! translation into the modes of the scheme and of the Newton workspace, Newton's settings
!! of the plain path, and the end-state tolerance they imply.
submodule (holosym_integrator) holosym_settings_checks
    use holosym_newton, only: newton_settings_valid, LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED
    use holosym_scheme, only: JACOBIAN_ASSEMBLED, JACOBIAN_RESIDUAL_DIFFERENCES, &
        HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_reduced_kernels_dd, only: double_double_floor
    implicit none

    !> A step whose end state misses a constraint by more than this (scaled as in
    !! manifold_residuals) has not converged: sqrt(epsilon).
    real(wp), parameter :: end_state_tolerance = sqrt(epsilon(1.0_wp))
    !> ... or this many times a looser Newton tolerance (`newton%tolerance`).
    real(wp), parameter :: end_state_factor = 1024
contains

    !> Whether every setting of the integrator is in its range; `message` names the first
    !! that is not: the Newton settings (`newton_settings_valid`), 0 < manifold_tolerance < 1
    !! (finite) and the option strings (linear_solver, jacobian, hessians, iteration,
    !! residual_sums: an explicit 'double-double' only in real128, on the reduced step,
    !! with a Newton tolerance of at least `double_double_floor`).
    module logical function settings_valid(self, message)
        class(constrained_integrator), intent(in) :: self
        character(len=:), allocatable, intent(out) :: message
        integer :: option
        if (newton_settings_valid(self%newton, message)) then
            ! Finiteness first: a NaN in an ordered comparison raises 'invalid'.
            if (.not. is_finite(self%manifold_tolerance)) then
                message = "manifold_tolerance must be finite, got " // &
                    real_str(self%manifold_tolerance)
            else if (self%manifold_tolerance <= 0 .or. self%manifold_tolerance >= 1) then
                message = "manifold_tolerance must be in (0, 1), got " // &
                    real_str(self%manifold_tolerance)
            end if
        end if
        if (len(message) == 0) then
            select case (self%linear_solver)
            case ("real128", "native", "mixed", "lapack")
            case default
                message = "linear_solver must be 'real128' or 'mixed'; got '" // &
                    trim(self%linear_solver) // "'"
            end select
        end if
        if (len(message) == 0) then
            select case (self%jacobian)
            case ("assembled", "residual-differences")
            case default
                message = "jacobian must be 'assembled' or 'residual-differences'; got '" // &
                    trim(self%jacobian) // "'"
            end select
        end if
        if (len(message) == 0) then
            select case (self%hessians)
            case ("automatic", "user", "differences")
            case default
                message = "hessians must be 'automatic', 'user' or 'differences'; got '" // &
                    trim(self%hessians) // "'"
            end select
        end if
        if (len(message) == 0) then
            select case (self%iteration)
            case ("automatic", "newton")
            case default
                message = "iteration must be 'automatic' or 'newton'; got '" // &
                    trim(self%iteration) // "'"
            end select
        end if
        if (len(message) == 0) call check_residual_sums(self, message)
        if (len(message) == 0 .and. self%path%main == STEP_REDUCED) then
            option = refused_option(self)
            if (option > 0) message = reduced_refusal(self, option)
        end if
        settings_valid = len(message) == 0
    end function settings_valid

    !> The `residual_sums` setting: its value, and where 'double-double' applies.
    subroutine check_residual_sums(self, message)
        class(constrained_integrator), intent(in) :: self
        character(len=:), allocatable, intent(inout) :: message
        select case (self%residual_sums)
        case ("automatic", "working")
        case ("double-double")
            if (wp_is_double) then
                message = "residual_sums = 'double-double' is for the real128 build " // &
                    "(real64 sums are already cheaper)"
            else if (self%path%main /= STEP_REDUCED) then
                message = "residual_sums = 'double-double' needs the reduced step (a " // &
                    "system declaring diagonal_mass, structured = .true.)"
            else if (self%newton%tolerance < double_double_floor) then
                message = "residual_sums = 'double-double' needs newton%tolerance >= " // &
                    real_str(double_double_floor) // " (the sums' rounding); got " // &
                    real_str(self%newton%tolerance)
            end if
        case default
            message = "residual_sums must be 'automatic', 'working' or 'double-double'; " // &
                "got '" // trim(self%residual_sums) // "'"
        end select
    end subroutine check_residual_sums

    !> Whether the reduced step sums its working-precision residuals in double-double
    !! arithmetic: `residual_sums` 'double-double', or 'automatic' in real128 with a Newton
    !! tolerance of at least `double_double_floor`.
    pure module logical function paired_sums(self)
        class(constrained_integrator), intent(in) :: self
        select case (self%residual_sums)
        case ("double-double")
            paired_sums = .true.
        case ("automatic")
            paired_sums = .not. wp_is_double
            if (paired_sums) paired_sums = self%newton%tolerance >= double_double_floor
        case default
            paired_sums = .false.
        end select
    end function paired_sums

    !> The first option the reduced step does not honour (1 simplified, 2 presolve, 3
    !! linear_solver, 4 jacobian, 5 linear_increments, 6 hessians 'user', 7 hessians
    !! 'differences'), or 0 when it honours them all (the general step honours every value:
    !! `structured = .false.` before `init`). The reduced step is simplified Newton with
    !! real64 factors of its assembled Newton matrix, a real64 first phase in real128 and
    !! first-order step results; its second derivatives are the system's `hessian`
    !! bindings when no sparsity is declared, else differences along the colours of the
    !! coupling graph. Decided without building a message: it runs before every step.
    pure integer function refused_option(self) result(option)
        class(constrained_integrator), intent(in) :: self
        associate (sparse => self%reduced%scheme%layout%sparse)
            if (.not. self%newton%simplified) then
                option = 1
            else if (.not. self%newton%presolve .and. .not. wp_is_double) then
                option = 2
            else if (self%linear_solver == "real128" .or. self%linear_solver == "native") then
                option = 3
            else if (self%jacobian /= "assembled") then
                option = 4
            else if (.not. self%linear_increments) then
                option = 5
            else if (self%hessians == "user" .and. sparse) then
                option = 6
            else if (self%hessians == "differences" .and. .not. sparse) then
                option = 7
            else
                option = 0
            end if
        end associate
    end function refused_option

    !> The refusal of option `option` (of `refused_option`), naming it.
    function reduced_refusal(self, option) result(message)
        class(constrained_integrator), intent(in) :: self
        integer, intent(in) :: option
        character(len=:), allocatable :: message
        select case (option)
        case (1)
            message = "newton%simplified = .false."
        case (2)
            message = "newton%presolve = .false."
        case (3)
            message = "linear_solver = '" // trim(self%linear_solver) // "'"
        case (4)
            message = "jacobian = '" // trim(self%jacobian) // "'"
        case (5)
            message = "linear_increments = .false."
        case (6)
            message = "hessians = 'user' (with a declared sparsity it differences the " // &
                "gradients along the colours of the coupling graph)"
        case default
            message = "hessians = 'differences' (without a declared sparsity it calls " // &
                "the system's hessian bindings)"
        end select
        message = "the reduced step (structured = .true., the path of this system) does " // &
            "not honour " // message // "; set structured = .false. before init for the " // &
            "general step, which honours it"
    end function reduced_refusal

    !> Largest scaled constraint residual of an accepted end state: `end_state_tolerance`,
    !! or `end_state_factor` times a looser Newton tolerance.
    module pure real(wp) function end_tolerance(self)
        class(constrained_integrator), intent(in) :: self
        end_tolerance = max(end_state_tolerance, end_state_factor * self%newton%tolerance)
    end function end_tolerance

    !> Translate the option strings into the modes of the scheme and the Newton workspace.
    !! Code HOLOSYM_INVALID_ARGUMENT names an unknown value.
    module subroutine apply_options(self, h, status)
        class(constrained_integrator), intent(inout) :: self
        real(wp), intent(in) :: h
        type(holosym_status_t), intent(inout) :: status
        integer :: modes(3)
        select case (self%linear_solver)
        case ("real128", "native")
            modes(1) = LINEAR_SOLVER_NATIVE
        case ("mixed", "lapack")
            modes(1) = LINEAR_SOLVER_MIXED
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "linear_solver must be " // &
                "'real128' or 'mixed'; got '" // trim(self%linear_solver) // "'")
            return
        end select
        select case (self%jacobian)
        case ("assembled")
            modes(2) = JACOBIAN_ASSEMBLED
        case ("residual-differences")
            modes(2) = JACOBIAN_RESIDUAL_DIFFERENCES
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "jacobian must be " // &
                "'assembled' or 'residual-differences'; got '" // trim(self%jacobian) // "'")
            return
        end select
        select case (self%hessians)
        case ("automatic", "user")
            modes(3) = HESSIANS_USER
        case ("differences")
            modes(3) = HESSIANS_DIFFERENCES
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "hessians must be " // &
                "'automatic', 'user' or 'differences'; got '" // trim(self%hessians) // "'")
            return
        end select
        ! Kept factors belong to one step size and one way of forming the Jacobian.
        if (any(modes /= self%applied_modes) .or. h /= self%workspace_h) then
            call self%workspace%invalidate()
            self%applied_modes = modes
            self%workspace_h = h
        end if
        self%workspace%linear_solver = modes(1)
        self%scheme%jacobian_mode = modes(2)
        self%scheme%hessian_mode = modes(3)
        self%scheme%linear_increments = self%linear_increments
    end subroutine apply_options

    !> True when any of the Newton speed options is in use.
    module pure logical function fast_options(self)
        class(constrained_integrator), intent(in) :: self
        fast_options = self%newton%simplified .or. self%newton%presolve .or. &
            (self%linear_solver /= "real128" .and. self%linear_solver /= "native")
    end function fast_options

    !> `settings` with the speed options of Newton's method off.
    module pure function plain_settings(settings) result(plain)
        type(newton_settings_t), intent(in) :: settings
        type(newton_settings_t) :: plain
        plain = settings
        plain%simplified = .false.
        plain%presolve = .false.
    end function plain_settings

end submodule holosym_settings_checks
