// Entry point of the surfel dispatch-arguments pass: one thread turns the count of chosen
// surfels into the splat pass's indirect workgroup counts (rows of DISPATCH_ROW workgroups).
//
// Spaces: none.

@compute @workgroup_size(1)
fn cs_main() {
    let groups = (atomicLoad(&tally[TALLY_DRAWN]) + SPLAT_GROUP - 1u) / SPLAT_GROUP;
    let rows = max((groups + DISPATCH_ROW - 1u) / DISPATCH_ROW, 1u);
    dispatch[0] = min(groups, DISPATCH_ROW);
    dispatch[1] = rows;
    dispatch[2] = 1u;
}
