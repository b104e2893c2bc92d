!> category: internal submodule (use holosym)
!! `step_tangent`: one step and the derivative of the step map applied to tangent vectors.
!! The derivative is the general scheme's (`discrete_scheme%tangent`) at the step's
!! solution: the integrator's own unknowns when the general step solved it, else the
!! general unknowns read off the accepted step's dense output at the nodes (both schemes
!! solve the same equations, so that point solves the general ones to round-off).
submodule (holosym_integrator) holosym_step_tangent
    use holosym_scheme, only: HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_tangent_space, only: tangent_residual, tangent_tolerance
    use holosym_status_codes, only: HOLOSYM_OFF_MANIFOLD
    implicit none

contains

    module subroutine integrator_step_tangent(self, sys, q, p, h, dq, dp, info, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(inout) :: q(:), p(:)
        real(wp), intent(in) :: h
        real(wp), intent(inout) :: dq(:, :), dp(:, :)
        type(step_info_t), intent(out), optional :: info
        type(holosym_status_t), intent(out), optional :: status
        type(holosym_status_t) :: local
        real(wp) :: qa(size(q)), pa(size(p)), dq_b(size(dq, 1), size(dq, 2))
        real(wp) :: dp_b(size(dp, 1), size(dp, 2))
        integer :: k

        call validate(self, sys, q, p, h, local)
        if (local%ok()) call check_tangents(sys, q, p, dq, dp, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        qa = q
        pa = p
        call self%step(sys, q, p, h, info, local)
        if (local%ok()) call linearise_last_step(self, sys, qa, pa, h, local)
        do k = 1, size(dq, 2)
            if (.not. local%ok()) exit
            call self%tangent_scheme%tangent(dq(:, k), dp(:, k), dq_b(:, k), dp_b(:, k), local)
        end do
        if (.not. local%ok()) then
            q = qa
            p = pa
            call set_status(status, local%code, local%message)
            return
        end if
        dq = dq_b
        dp = dp_b
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine integrator_step_tangent

    !> The tangent vectors: n x k alike, finite, in the tangent space at (q, p).
    subroutine check_tangents(sys, q, p, dq, dp, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), dq(:, :), dp(:, :)
        type(holosym_status_t), intent(out) :: status
        real(wp) :: residual
        integer :: k
        if (size(dq, 1) /= sys%n .or. size(dp, 1) /= sys%n .or. &
            size(dq, 2) /= size(dp, 2)) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "step_tangent: dq and dp must " &
                // "both be n x k (n = " // int_str(sys%n) // "); got " &
                // int_str(size(dq, 1)) // " x " // int_str(size(dq, 2)) // " and " &
                // int_str(size(dp, 1)) // " x " // int_str(size(dp, 2)))
            return
        end if
        do k = 1, size(dq, 2)
            if (.not. (all(is_finite(dq(:, k))) .and. all(is_finite(dp(:, k))))) then
                call set_status(status, HOLOSYM_INVALID_ARGUMENT, "step_tangent: tangent " &
                    // "vector " // int_str(k) // " has a non-finite entry")
                return
            end if
            residual = tangent_residual(sys, q, p, dq(:, k), dp(:, k))
            if (.not. (residual <= tangent_tolerance)) then
                call set_status(status, HOLOSYM_OFF_MANIFOLD, "step_tangent: tangent vector " &
                    // int_str(k) // " is not tangent to the constraint manifold at the " &
                    // "start state (residual " // real_str(residual) // " > " &
                    // real_str(tangent_tolerance) // "; project_tangent projects it)")
                return
            end if
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine check_tangents

    !> Linearise the general scheme's equations at the solution of the step just
    !! accepted, from (qa, pa) with h.
    subroutine linearise_last_step(self, sys, qa, pa, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: qa(:), pa(:), h
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: x(:)
        if (.not. self%tangent_ready) then
            call self%tangent_scheme%init(self%scheme%order_m, self%scheme%order_n, &
                                          self%scheme%gauss_points, sys%n, sys%m, status)
            if (.not. status%ok()) return
            self%tangent_ready = .true.
        end if
        associate (scheme => self%tangent_scheme)
            scheme%hessian_mode = merge(HESSIANS_DIFFERENCES, HESSIANS_USER, &
                                        self%hessians == "differences")
            call scheme%set_step(sys, qa, pa, h)
            allocate (x(scheme%nx))
            if (self%path%last == STEP_GENERAL) then
                x = self%last_x
            else
                call unknowns_from_dense(self, x)
            end if
            call scheme%linearise(x, status)
        end associate
    end subroutine linearise_last_step

    !> The general unknowns of the last accepted step from its dense output at the nodes.
    subroutine unknowns_from_dense(self, x)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(out) :: x(:)
        real(wp) :: q(self%tangent_scheme%n, 0:self%tangent_scheme%order_m)
        real(wp) :: p(self%tangent_scheme%n, 0:self%tangent_scheme%order_n)
        real(wp) :: lambda(self%tangent_scheme%m, 0:self%tangent_scheme%order_m)
        real(wp) :: q_unused(self%tangent_scheme%n), lambda_unused(self%tangent_scheme%m)
        integer :: i
        associate (scheme => self%tangent_scheme)
            do i = 0, scheme%order_m
                call path_dense(self, scheme%disp_nodes(i), q(:, i), q_unused, lambda(:, i))
            end do
            do i = 0, scheme%order_n
                call path_dense(self, scheme%mom_nodes(i), q_unused, p(:, i), lambda_unused)
            end do
            call scheme%unknowns_from_nodes(q, p, lambda, x)
        end associate
    end subroutine unknowns_from_dense

end submodule holosym_step_tangent
