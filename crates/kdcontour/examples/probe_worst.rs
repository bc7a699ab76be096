use glam::Vec3;
use kdcontour::*;
fn main() {
    let name = std::env::args().nth(1).unwrap();
    let res: u32 = std::env::args().nth(2).unwrap().parse().unwrap();
    let scene = scenes::scene(&name).unwrap();
    let grid = Grid::cube(1.0, res);
    let set = Settings::default();
    let v = hermite::sample(&*scene.field, &grid, &set).unwrap();
    let h = hermite::Hermite::new(&*scene.field, &grid, &v, &set).unwrap();
    let f = &*scene.field;
    let mut worst = (0.0, 0usize, 0usize);
    for (ci, c) in h.cells.iter().enumerate() {
        let cc = Vec3::new(c.coord[0] as f32, c.coord[1] as f32, c.coord[2] as f32);
        let t = cell::CellTables::get().cell(c.config, c.mask);
        for k in 0..t.count as usize {
            let q = h.patch_qef[c.patch_base as usize + k];
            let (x, _) = q.solve(cc, cc + Vec3::ONE);
            let w = grid.to_world(x);
            let d = f.value(w).abs() / f.gradient(w).length() / grid.cell_size;
            if d > worst.0 {
                worst = (d, ci, k);
            }
        }
    }
    let c = h.cells[worst.1];
    let cc = Vec3::new(c.coord[0] as f32, c.coord[1] as f32, c.coord[2] as f32);
    let q = h.patch_qef[c.patch_base as usize + worst.2];
    let (x, e) = q.solve(cc, cc + Vec3::ONE);
    println!("worst {} cells at cell {:?} patch {} config {:08b} mask {}: vertex {x} err {e} count {} mass {}", worst.0, c.coord, worst.2, c.config, c.mask, q.count, q.mass_point());
    println!("eig {:?}", qef::sym_eigen(q.ata));
    println!("world {}", grid.to_world(x));
}
