!> category: C interface (include/holosym.h)
!! The live handles of the C interface: every handle `holosym_create` or
!! `holosym_model_create` returned and `holosym_destroy` has not freed. Each C function
!! looks its handle up here before reading it, so a destroyed handle, a handle destroyed
!! twice or a pointer the library never returned is refused (HOLOSYM_NOT_INITIALIZED)
!! instead of being read. The addresses are kept sorted (binary search: a lookup costs
!! log2 of the live handles); the registry is guarded by one OpenMP critical section, so
!! handles may be created, used and destroyed on several threads at once.
!!
!! What no registry can see: a handle freed and its address returned again by a later
!! create is that later handle.
module holosym_c_registry
    use, intrinsic :: iso_c_binding, only: c_ptr, c_intptr_t, c_associated
    implicit none
    private

    public :: register_handle, forget_handle, is_live_handle

    ! The live addresses, sorted ascending: live(1:live_count).
    integer(c_intptr_t), allocatable, save :: live(:)
    integer, save :: live_count = 0

contains

    !> The address held by `ptr`.
    pure integer(c_intptr_t) function address_of(ptr) result(address)
        type(c_ptr), intent(in) :: ptr
        address = transfer(ptr, address)
    end function address_of

    !> The position of `address` in live(1:live_count), or -(the position it would take).
    pure integer function search(table, count, address) result(position)
        integer(c_intptr_t), intent(in) :: table(:)
        integer, intent(in) :: count
        integer(c_intptr_t), intent(in) :: address
        integer :: low, high, middle
        low = 1
        high = count
        do while (low <= high)
            middle = low + (high - low) / 2
            if (table(middle) == address) then
                position = middle
                return
            else if (table(middle) < address) then
                low = middle + 1
            else
                high = middle - 1
            end if
        end do
        position = -low
    end function search

    !> Record the handle at `ptr` as live (a NULL pointer is ignored).
    subroutine register_handle(ptr)
        type(c_ptr), intent(in) :: ptr !! the new handle
        integer(c_intptr_t), allocatable :: longer(:)
        integer(c_intptr_t) :: address
        integer :: position
        if (.not. c_associated(ptr)) return
        address = address_of(ptr)
        !$omp critical (holosym_c_handles)
        if (.not. allocated(live)) allocate (live(16))
        position = search(live, live_count, address)
        if (position < 0) then
            position = -position
            if (live_count == size(live)) then
                allocate (longer(2 * size(live)))
                longer(1:live_count) = live(1:live_count)
                call move_alloc(longer, live)
            end if
            live(position + 1:live_count + 1) = live(position:live_count)
            live(position) = address
            live_count = live_count + 1
        end if
        !$omp end critical (holosym_c_handles)
    end subroutine register_handle

    !> Remove the handle at `ptr` from the live ones; false when it was not live (NULL,
    !! destroyed already, or never returned by the library).
    logical function forget_handle(ptr) result(found)
        type(c_ptr), intent(in) :: ptr !! the handle
        integer :: position
        found = .false.
        if (.not. c_associated(ptr)) return
        !$omp critical (holosym_c_handles)
        position = 0
        if (allocated(live)) position = search(live, live_count, address_of(ptr))
        if (position > 0) then
            live(position:live_count - 1) = live(position + 1:live_count)
            live_count = live_count - 1
            found = .true.
        end if
        !$omp end critical (holosym_c_handles)
    end function forget_handle

    !> Whether `ptr` is a live handle.
    logical function is_live_handle(ptr) result(found)
        type(c_ptr), intent(in) :: ptr !! the handle
        found = .false.
        if (.not. c_associated(ptr)) return
        !$omp critical (holosym_c_handles)
        if (allocated(live)) found = search(live, live_count, address_of(ptr)) > 0
        !$omp end critical (holosym_c_handles)
    end function is_live_handle

end module holosym_c_registry
